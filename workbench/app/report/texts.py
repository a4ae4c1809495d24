"""The report's own words: problem summaries, figure captions, errata, findings.

Plain summaries of the problems, captions of their figures, the errata of the papers the
workbench confirms and what it found beyond the papers.

Each erratum and finding names the problem whose run confirms it; the first page shows it
as confirmed only when that problem ran and met all its comparisons in this report. A
problem module may define ``SUMMARY`` (plain words) to replace its entry here.
"""

from __future__ import annotations

__all__ = ["SUMMARIES", "CAPTIONS", "COVER", "ERRATA", "FINDINGS", "INTRO"]

INTRO = (
    "The workbench writes each pendulum model once, as a CasADi expression graph in "
    "ambient coordinates (rotation matrices and unit vectors, no angles), and derives "
    "everything else from that graph: simulations, linearisations, equilibria, stable "
    "manifolds, optimal swing-ups and C controllers. Each problem below reproduces a "
    "result of one of four papers (Chaturvedi, Lee, Leok, McClamroch) and puts every number "
    "the paper prints, or a closed form, beside the workbench's own, with the deviation and "
    "the tolerance it is held to. In the pictures e3 points down, along gravity."
)

SUMMARIES: dict[str, str] = {
    "cart_nonlinear_inverted": (
        "A single spherical pendulum is balanced upside down on a cart that moves in the "
        "plane, by the nonlinear controller of paper 003. The closed loop of its Fig. 5 "
        "converges, its Lyapunov function never rises, and the region the paper's argument "
        "certifies is computed and checked by sampling: every sampled start in it converges, "
        "and the true basin is far larger."),
    "chain_equilibria": (
        "A chain of n spherical links hanging from a cart has 2^n equilibria: each link "
        "points straight down or straight up. Newton's method on the manifold finds all of "
        "them for n = 1 to 6 from the model's graph alone."),
    "chain_linearization": (
        "The chain on a cart is linearised at every one of its equilibria, from the graph, "
        "and compared with the paper's formula (16) (with its errata). Only the hanging "
        "chain has no unstable motion; every equilibrium is controllable by the cart force "
        "(PBH test), while the classical Kalman rank test wrongly says otherwise from three "
        "links on."),
    "chain_lqr": (
        "A five-link chain on a cart is stabilised by a linear-quadratic regulator turned "
        "into a smooth nonlinear feedback on the spheres (paper 003 (19)). The closed loops "
        "of the paper's Figs. 3 and 4 converge, at exactly the rate the linearisation "
        "predicts."),
    "extremes": (
        "The workbench pushed to its limits: nearly balanced bodies, badly conditioned "
        "inertia, very fast and very slow motion, parameters at singular values, long chains, "
        "hard swing-ups and bad input. Each case says what was done, whether the answer is "
        "right (against a closed form where one exists) or fails clearly, and what it cost."),
    "inverted_manifold_velocity_feedback": (
        "Under angular-velocity feedback almost every motion of the 3D pendulum comes to "
        "rest hanging; the exceptions form a thin set that ends at the inverted equilibrium. "
        "A slice of that set is computed and shown to avoid the set N of paper 001, as its "
        "Lemma 4 says."),
    "pendulum3d_invariants": (
        "The 3D pendulum is simulated with its full model on the rotation group and with "
        "its two reduced models; they agree with each other, conserve energy and angular "
        "momentum, and reproduce the planar and spherical pendulums as special cases "
        "(paper 000)."),
    "pendulum3d_linearization": (
        "The 3D pendulum is linearised at its hanging and inverted equilibria with the full, "
        "the Lagrange-Poincare and the Routh models, directly from the graphs; the spectra "
        "equal the paper's closed forms to rounding."),
    "poincare_3d_pendulum": (
        "Poincare sections of the 3D pendulum at increasing energy show the motion turning "
        "from regular to chaotic and back, as paper 000's Fig. 5.1 does, with finite-time "
        "Lyapunov exponents and the geometric phase checked against reconstruction."),
    "relative_equilibria": (
        "Steady rotations of the 3D pendulum about the vertical (relative equilibria) are "
        "traced by continuation from the model's graph: all the families of paper 000's "
        "elliptic cylinder, where they begin and end, and where they lose stability, which "
        "the paper does not give. The paper's closed form is confirmed only with its "
        "erratum."),
    "s2_pd_eigenstructure": (
        "A spherical pendulum under geometric PD control (paper 002): the eigenvalues and "
        "eigenvectors at the hanging and inverted equilibria, and the stable directions of "
        "the inverted saddle from which its stable manifold is grown."),
    "so3_pd_closed_loop": (
        "Geometric PD control of an attitude on SO(3) (paper 002): generic starts converge to "
        "the desired attitude, and starts near each of the three saddle attitudes leave "
        "along their unstable directions."),
    "so3_pd_eigenstructure": (
        "Geometric PD control on SO(3) (paper 002): the eigenvalue table of the desired "
        "attitude and of the three saddles, each with 3, 2 or 1 unstable modes."),
    "stable_manifold_s2": (
        "The states of the controlled spherical pendulum that end at the inverted saddle "
        "instead of the desired equilibrium form its stable manifold, computed by "
        "integrating backward in time from a small circle of stable directions (paper 002 "
        "Fig. 1)."),
    "stable_manifolds_so3": (
        "The stable manifolds of the three saddles of PD control on SO(3), computed by "
        "backward integration and drawn as the paths of the body axes on a sphere (paper 002 "
        "Figs. 2, 4, 5)."),
    "swingup_3d_pendulum": (
        "The 3D pendulum is swung up from hanging to inverted with bounded body torques, by "
        "minimum effort and by minimum time, with Ipopt; the full and the reduced models give "
        "the same optimum."),
    "swingup_double_spherical_cart": (
        "A double spherical pendulum on a cart is swung up to balance, with Ipopt, by "
        "continuation from a single-link problem, and held there by a time-varying LQR "
        "that recovers from perturbed starts."),
    "swingup_spherical_cart": (
        "A spherical pendulum on a cart is swung up to balance with Ipopt; the problem has "
        "several local optima, which differ in the number of swings. A time-varying LQR "
        "tracks the optimal swing-up from perturbed starts."),
    "velocity_feedback_hanging": (
        "Saturated angular-velocity feedback brings the 3D pendulum from nearly upside down "
        "to rest hanging, reproducing paper 001's Section 7 (Figs. 3-5); sampled starts "
        "everywhere converge, as almost-global stability says."),
    "velocity_feedback_linearization": (
        "The closed loop of angular-velocity feedback linearised at the hanging and inverted "
        "equilibria: the spectra of paper 001's Lemmas 1-4 and Remarks 2-3, and the "
        "characteristic polynomial derived symbolically from the graph."),
    "work_precision": (
        "How much accuracy each integrator buys for its cost, the convergence orders fitted "
        "from errors against step size, and over long times the bounded energy error of the "
        "variational integrators against the drift of the others."),
}

CAPTIONS: dict[tuple[str, str], str] = {
    ("cart_nonlinear_inverted", "fig5"): (
        "Paper 003 Fig. 5: the inverted spherical pendulum on a cart under the nonlinear "
        "controller (21), (26): cart position, link direction, control force and Lyapunov "
        "function V (25) over time."),
    ("chain_equilibria", "newton_convergence"): (
        "Newton's method on the manifold converging to the 2^n equilibria of the chain on a "
        "cart: residual against iteration."),
    ("chain_lqr", "errors"): (
        "Paper 003 Figs. 3-4: the five-link chain under the geometric LQR feedback (19); "
        "distance from the hanging equilibrium against time, decaying at the spectral "
        "abscissa."),
    ("inverted_manifold_velocity_feedback", "slice_of_M_i"): (
        "A slice of the stable manifold M_i of the inverted equilibrium under velocity "
        "feedback, against the set N of paper 001 (Lemma 4): the slice never enters N."),
    ("pendulum3d_invariants", "invariant_drift"): (
        "Drift of the energy and of the vertical angular momentum of the 3D pendulum along "
        "the simulations of the full and reduced models."),
    ("poincare_3d_pendulum", "poincare_maps"): (
        "Paper 000 Fig. 5.1: Poincare sections of the 3D pendulum at five energies, from "
        "regular to chaotic and back."),
    ("relative_equilibria", "relative_equilibria"): (
        "Relative equilibria of the elliptic cylinder (paper 000 Sec. 4.3): the families "
        "L1-L4 traced by continuation, with their stability and special points."),
    ("so3_pd_closed_loop", "saddle_escapes"): (
        "Geometric PD on SO(3): trajectories started near each saddle attitude leave along "
        "its unstable directions and converge to the desired attitude."),
    ("stable_manifold_s2", "stable_manifold_fig1"): (
        "Paper 002 Fig. 1: the stable manifold of the inverted equilibrium of the spherical "
        "pendulum under PD control, on the sphere, coloured by |omega|."),
    ("swingup_3d_pendulum", "minimum_effort"): (
        "Minimum-effort swing-up of the 3D pendulum with bounded body torques: the attitude "
        "path and the torques over time."),
    ("swingup_3d_pendulum", "minimum_time"): (
        "Minimum-time swing-up of the 3D pendulum with bounded body torques."),
    ("swingup_3d_pendulum", "full_model_body_axes"): (
        "The swing-up of the full model on SO(3), drawn as the paths of the three body axes."),
    ("swingup_double_spherical_cart", "swingup"): (
        "Optimal swing-up of the double spherical pendulum on a cart: both link directions "
        "on their spheres (up is -e3) and the cart force; thin lines are TVLQR closed loops "
        "from perturbed starts."),
    ("swingup_spherical_cart", "swingup"): (
        "Optimal swing-up of the spherical pendulum on a cart (|u_i| <= 10 N): the link "
        "direction on its sphere (up is -e3) and the cart force; thin lines are TVLQR closed "
        "loops from perturbed starts."),
    ("swingup_spherical_cart", "harder_case"): (
        "The harder swing-up with |u_i| <= 2 N, reached by continuation in the bound."),
    ("velocity_feedback_hanging", "figs_3_5"): (
        "Paper 001 Figs. 3-5: the 3D pendulum under saturated velocity feedback from nearly "
        "inverted: tilt angle, angular velocity and control moment over time."),
    ("work_precision", "work_precision_pendulum3d"): (
        "Work against precision of the integrators on the chaotic 3D pendulum."),
    ("work_precision", "work_precision_chain3"): (
        "Work against precision of the integrators on the three-link chain on a cart."),
    ("work_precision", "long_time_pendulum3d"): (
        "Energy error over long times on the 3D pendulum: bounded for the variational "
        "integrator, drifting for the others."),
    ("work_precision", "long_time_spherical"): (
        "Energy error over long times on the spherical pendulum."),
    ("work_precision", "convergence_orders"): (
        "Convergence orders: error against step size, with the fitted slopes."),
}

COVER: list[tuple[str, str]] = [
    ("swingup_double_spherical_cart", "swingup"),
    ("swingup_spherical_cart", "swingup"),
    ("stable_manifold_s2", "stable_manifold_fig1"),
    ("swingup_3d_pendulum", "minimum_effort"),
    ("relative_equilibria", "relative_equilibria"),
]
"""Figures for the first page, by ``(problem, figure)``, the first one available first: a
swing-up to balance (what the workbench is for) and the stable manifold of paper 002."""

ERRATA: list[tuple[str, str, str]] = [
    ("000", "Prop. 9 (and (4.18), (5.18)): the attitude of a relative equilibrium is "
            "Gamma_e = -n_a/|n_a| for every alpha, not -sgn(alpha) n_a/|n_a|; the limits "
            "alpha -> 0+ and 0- are swapped in the proof.", "relative_equilibria"),
    ("001", "Section 7: the printed R(0) is not a rotation (|R^T R - I| about 1.7e-6); kept "
            "as printed the tilt cannot get below 0.06 degrees, projected it converges.",
     "velocity_feedback_hanging"),
    ("002", "(19): v6 = e3 + lambda6 e6; the E^s_loc of exp(pi e3-hat) has Omega-component "
            "+lambda5 alpha5 e3; in (7) C is 2x6.", "so3_pd_eigenstructure"),
    ("003", "(12), first row: the centrifugal term is sum_j M_0j |omega_j|^2 C^T q_j (the "
            "text prints q_1).", "chain_linearization"),
    ("003", "(16): the last block of G_qq is s_n m_n g l_n; (17) reads "
            "M_qq x_q'' + G_qq x_q = M_qx u; appendix (39) drops the factors s_i.",
     "chain_linearization"),
    ("003", "(21): the matrix multiplies mu; there is no inverse.", "cart_nonlinear_inverted"),
]

FINDINGS: list[tuple[str, str]] = [
    ("Stability along the relative-equilibrium families of paper 000: L2 stable "
     "throughout; L3 and L4 lose stability at alpha = 2.2926 and 4.3818, at folds of mu.",
     "relative_equilibria"),
    ("The Kalman rank test wrongly reports the chain on a cart uncontrollable from three "
     "links on (condition numbers up to 1e23); the PBH test proves it controllable.",
     "chain_linearization"),
    ("The domain of attraction certified for the cart controller is a small part of the "
     "true basin (sampled basin about 370 times larger).", "cart_nonlinear_inverted"),
    ("The swing-up of the spherical pendulum on a cart has several local optima, which "
     "differ in the number of swings.", "swingup_spherical_cart"),
    ("Variational integrators keep the energy error bounded over 10^4 periods, but at "
     "h = 0.01 RK4's drifting error stays smaller for the first ~4x10^4 periods.",
     "work_precision"),
    ("A long horizon on a coarse transcription can converge to something that is no "
     "trajectory of the model; every solve now measures its local defect.", "extremes"),
]
