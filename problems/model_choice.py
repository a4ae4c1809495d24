"""Choose the model for a scene by measured speed and accuracy: the 3D pendulum's levels.

For each scene (initial states, a horizon, the outputs that matter, a tolerance on them)
``workbench.study.compare_models`` runs every level of the model that applies -- the full
model, its Lagrange-Poincare and Routh models by each symmetry (derived by
``workbench.mechanics.reduce``, with reconstruction when the outputs are not invariant),
paper 000's special cases whose assumptions the scene meets (Lagrange top, spherical,
planar; checked numerically: ``models.pendulum3d_levels.special_cases``), the
linearisation when the scene stays near an equilibrium -- times each (CPU, median of
repeats) and measures its output error against the full model at a tight, checked
tolerance, and picks the cheapest level within the tolerance. Scenes: paper 000's
elliptic cylinder near hanging and tumbling, an axisymmetric top spinning and swinging
in a plane, and (beyond the papers) the 3D pendulum on a cart drifting near hanging.
"""

from __future__ import annotations

from problems._model_choice_levels import cart_scene, pendulum_scenes, top_scenes
from workbench.study import Result, choice_figure, compare_models

TITLE = "Choosing the 3D pendulum's model level for a scene by measured CPU time and error"

BODY = {"J": [[0.4486, 0.0, 0.0], [0.0, 0.3943, 0.0], [0.0, 0.0, 0.0772]],
        "rho": [-0.0140, 0.1044, 0.4989], "m": 1.0, "g": 9.81}  # paper 000 Section 4.3
KNOBS = {"method": "cvodes", "rtol": 1e-10, "atol": 1e-10, "reference_rtol": 1e-13,
         "check_rtol": 1e-12, "reference_margin": 0.01}
AMPLITUDE = 2e-3  # tilt of the near-hanging scenes [rad]
SPEEDUP = 2.0  # the near-hanging scenes' choice must take <= 1/2 the full model's CPU time
PAYS = ("near hanging", "cart")


def solve(*, quick: bool = False) -> Result:
    """Run the problem.

    Parameters
    ----------
    quick : bool
        Horizon 40 s instead of 100 s (tumbling: a tenth, the planar swing: half of it), 3
        timed repeats instead of 5.

    Returns
    -------
    Result

    Notes
    -----
    Every level integrates with CVODES (Adams) at rtol = atol = 1e-10, unforced; the
    reference is the full model at 1e-13, checked against 1e-12 (they must agree to 1/100
    of the scene's tolerance). Rows per scene: the chosen level's max output error (<= the
    scene's tolerance), the reference check; for the two near-hanging scenes (long horizon)
    the chosen level's CPU time over the full model's (<= 1/2).
    """
    import numpy as np

    res = Result("model_choice", TITLE, quick=quick)
    horizon, repeats = (40.0, 3) if quick else (100.0, 5)
    body = {k: np.asarray(v, dtype=float) for k, v in BODY.items()}
    with res.timed("scenes"):
        models, scenes = zip(pendulum_scenes(body, horizon=horizon, amplitude=AMPLITUDE,
                                             n_states=3, seed=0),
                             top_scenes(horizon=horizon),
                             cart_scene(horizon=horizon, amplitude=AMPLITUDE, n_states=3,
                                        seed=0), strict=True)
    choices = {}
    for key, kw in {k: v for s in scenes for k, v in s.items()}.items():
        with res.timed(f"compare: {key}"):
            choices[key] = compare_models(**kw, **KNOBS, repeats=repeats,
                                          raise_on_failure=False)
    for key, ch in choices.items():
        tol = ch.tolerance
        err = ch.chosen.error if ch.chosen is not None else float("inf")
        res.compare(f"{ch.scene}: max output error of the chosen level ({ch.choice})", 0.0,
                    err, tolerance=tol, source="full model at rtol 1e-13")
        res.compare(f"{ch.scene}: reference at rtol 1e-13 vs 1e-12, max output difference",
                    0.0, ch.reference["difference"], tolerance=KNOBS["reference_margin"] * tol,
                    source="two reference runs")
        if key in PAYS:
            ratio = 1.0 / ch.speedup if ch.speedup else float("inf")
            res.compare(f"{ch.scene}: CPU time of the chosen level / full model's", 0.0, ratio,
                        tolerance=1.0 / SPEEDUP, source=f"measured in this run, {repeats} "
                        "repeats (median)", headline=key == "near hanging")
        res.notes += [f"{ch.scene}: choice {ch.choice}" + (
            f", {ch.speedup:.1f}x less CPU than full" if ch.speedup else "") + "."] + [
            f"{ch.scene}: {name}: {why}." for name, why in ch.excluded.items()]
    ratios: dict[str, list[float]] = {}
    for ch in choices.values():
        full = ch.level("full").cpu_seconds
        for lv in ch.levels:
            if lv.cpu_seconds is not None and lv.kind.value != "full":
                ratios.setdefault(lv.kind.value, []).append(lv.cpu_seconds / full)
    res.notes.append("Measured CPU time over the full model's, by kind of level (all scenes): "
                     + "; ".join(f"{k} {min(v):.2g} .. {max(v):.2g}" for k, v in ratios.items())
                     + ". Below 1 the level is cheaper.")
    columns = ("level", "kind", "applies", "cpu_seconds", "build_seconds", "error", "meets",
               "chosen", "why_not")
    res.values = {"knobs": {**KNOBS, "repeats": repeats, "horizon": horizon},
                  **{ch.scene: {"choice": ch.choice, "speedup": ch.speedup,
                                "tolerance": ch.tolerance, "reference": ch.reference,
                                "levels": [{c: row[c] for c in columns} for row in ch.table()]}
                     for ch in choices.values()}}
    res.figure("model_choice", choice_figure(list(choices.values()), ncols=3), caption=(
        "CPU time of a run (median of repeats, over all the scene's states) against the max "
        "output error against the full model at rtol 1e-13, for each level that applies; "
        "dashed: the scene's tolerance; ringed: the chosen level (the cheapest within the "
        "tolerance). Levels that do not apply are listed in the notes with the reason."))
    res.use(*models)
    return res.finish()


if __name__ == "__main__":
    from workbench.study import run_script

    run_script(solve)
