#!/usr/bin/env python3
"""Reference values of the guided sampler's densities for tests/guided_pdfs.rs.

Evaluates the numpy/scipy reference implementations of verify_guided_pdfs.py (the spec's
numerical checks, kept outside the repository in ../shared/reference/) at fixed inputs and
writes them, with full (round-trip) precision, to tests/data/guided_pdfs.csv: one case a
line, comma-separated, the kind first ('#' starts a comment line):

  mass   d r value                      M_d(r): chi3_mass for d = 3; erf(r/sqrt2), 1 - e^{-r^2/2}
  dir3   label r x(3) mu(3) S(6) w(3) beta value accurate
                                         value: pdf_dir_gauss (r = inf) or pdf_dir_gauss_trunc
                                         (normalised); accurate: the same closed form in
                                         50-digit mpmath; S as S00 S01 S02 S11 S12 S22
  plane  label s(3) t(3) n(3) g(3) o(3) w(3) m(2) e(4) sd(2) value
                                         the plane variant (check 3): q2(P) t_P^2 / |n.w| with
                                         q2 the kernel's truncated 2D Gaussian, e = e00 e01 e10
                                         e11 (eigenvectors as columns), sd its std devs

`dir3` covers the untruncated density and r = 2 and 3, origins inside and outside the
ellipsoid, far-tail directions (beta << 0, down to beta ~ -27), and beta = -4.2, -3.6, -3.0
(where Phi(beta) needs erfc between 2 and 3). The plane inputs are
rounded to float32 first (lodestar's frames, points and kernels are f32), and the plane
formula is evaluated exactly as lodestar's `Kernel::density` writes the Gaussian (eigen
form) so that the two agree to rounding; it is cross-checked against verify's inverse-
covariance form. Every dir3 value is also evaluated by the same closed form in 50-digit mpmath
(written as a second value: scipy's float64 evaluation loses up to ~3e-8 in the far tail, see
dir3_tolerance).

Run:  python3 tests/data/gen_guided_pdfs.py [path/to/verify_guided_pdfs.py]
      (default ../shared/reference/verify_guided_pdfs.py relative to the repository root;
      needs numpy, scipy and mpmath). The output is committed: CI does not need Python.
"""
import importlib.util
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
DEFAULT_REF = os.path.join(REPO, "..", "shared", "reference", "verify_guided_pdfs.py")
OUT = os.path.join(HERE, "guided_pdfs.csv")


def load_reference(path):
    spec = importlib.util.spec_from_file_location("verify_guided_pdfs", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)  # defines functions only; checks run under __main__
    return mod


def fmt(v):
    v = float(v)
    if math.isinf(v):
        return "inf" if v > 0 else "-inf"
    return repr(v)


def cov(sig, angles):
    """S = R diag(sig^2) R^T with R from three fixed rotation angles (deterministic)."""
    a, b, c = angles
    rz = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
    ry = np.array([[math.cos(b), 0, math.sin(b)], [0, 1, 0], [-math.sin(b), 0, math.cos(b)]])
    rx = np.array([[1, 0, 0], [0, math.cos(c), -math.sin(c)], [0, math.sin(c), math.cos(c)]])
    r = rz @ ry @ rx
    s = r @ np.diag(np.square(sig)) @ r.T
    return 0.5 * (s + s.T)


def unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def mp_dir_density(x, mu, S, w, r):
    """The spec's closed form (untruncated, or truncated to radius r and normalised) in
    50-digit arithmetic from the same float64 inputs: the accurate value, free of the
    cancellation that float64 suffers in the far tail (beta << 0)."""
    import mpmath as mp

    mp.mp.dps = 50
    Sm = mp.matrix(S.tolist())
    A = Sm ** -1
    m = mp.matrix([mp.mpf(mu[i]) - mp.mpf(x[i]) for i in range(3)])
    wv = mp.matrix([mp.mpf(w[i]) for i in range(3)])
    a = (wv.T * A * wv)[0]
    b = (wv.T * A * m)[0]
    c = (m.T * A * m)[0]
    beta = b / mp.sqrt(a)
    q = c - beta * beta
    front = mp.exp(-q / 2) / (2 * mp.pi * mp.sqrt(mp.det(Sm)) * a ** mp.mpf(1.5))
    if math.isinf(r):
        return front * ((1 + beta * beta) * mp.ncdf(beta) + beta * mp.npdf(beta))
    h2 = r * r - q
    if h2 <= 0:
        return mp.mpf(0)
    h = mp.sqrt(h2)
    lo = max(-h, -beta)
    if h <= lo:
        return mp.mpf(0)

    def G(s):
        return (1 + beta * beta) * mp.ncdf(s) - (2 * beta + s) * mp.npdf(s)

    mass = mp.erf(r / mp.sqrt(2)) - mp.sqrt(2 / mp.pi) * r * mp.exp(-mp.mpf(r) ** 2 / 2)
    return front * (G(h) - G(lo)) / mass


def dir3_cases():
    """(label, x, mu, S, [directions]) with directions towards the bulk, random, and away."""
    rng = np.random.default_rng(20180611)
    configs = [
        ("far-aniso", np.zeros(3), np.array([0.3, -0.2, 2.0]),
         cov([0.5, 0.2, 0.05], (0.3, -0.7, 1.1))),
        ("beam", np.zeros(3), np.array([0.0, 0.0, 1.5]), np.diag([0.02, 0.02, 0.8]) ** 2),
        ("near-mean", np.array([0.05, -0.1, 0.02]), np.array([0.1, 0.05, 0.2]),
         cov([0.4, 0.3, 0.1], (1.3, 0.4, -0.2))),
        ("inside", np.zeros(3), np.array([0.05, -0.03, 0.15]),
         cov([0.3, 0.2, 0.1], (-0.5, 0.9, 0.25))),
        ("far-tail", np.array([0.2, 0.1, -0.3]), np.array([0.2, 0.1, 3.7]),
         cov([0.2, 0.15, 0.13], (0.7, 0.2, -1.4))),
    ]
    out = []
    for label, x, mu, S in configs:
        m = mu - x
        sd = np.sqrt(np.diag(S))
        dirs = [unit(m)]
        for k in range(3):
            dirs.append(unit(m + (0.6 + 0.6 * k) * rng.normal(size=3) * sd))
        for _ in range(2):
            dirs.append(unit(rng.normal(size=3)))
        dirs.append(unit(-m))  # away from the mean: beta << 0 when the mean is far
        dirs.append(unit(-m + 0.3 * np.linalg.norm(m) * rng.normal(size=3)))
        if label.startswith("far"):
            # beta in the range where Phi(beta) needs erfc(x) for 2 < x < 3.
            for target in (-4.2, -3.6, -3.0):
                dirs.append(direction_with_beta(x, mu, S, target, rng))
        out.append((label, x, mu, S, dirs))
    return out


def direction_with_beta(x, mu, S, target, rng):
    """A unit direction w with beta(w) = target, by bisection on the great circle from
    (mu - x) (beta = sqrt(c)) to -(mu - x) (beta = -sqrt(c)) through a random direction."""
    A = np.linalg.inv(S)
    m = mu - x
    u = unit(m)
    v = rng.normal(size=3)
    v = unit(v - (v @ u) * u)

    def beta(theta):
        w = math.cos(theta) * u + math.sin(theta) * v
        return (w @ A @ m) / math.sqrt(w @ A @ w), w

    lo, hi = 0.0, math.pi
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if beta(mid)[0] > target:
            lo = mid
        else:
            hi = mid
    return beta(0.5 * (lo + hi))[1]


def dir3_tolerance(beta):
    """Relative tolerance of tests/guided_pdfs.rs for a dir3 value (keep in step with it; the
    Rust test adds an allowance for lodestar's erfc between 2 and 3, see erfc_allowance there):
    1e-9, plus for beta < 0 the float64 cancellation of the bracket (1 + b^2) Phi(b) + b phi(b):
    the terms exceed their sum by ~b^4/2 and each carries a relative rounding error ~b^2 eps
    (from exp(-b^2/2)), so the sum is good to ~b^6 eps / 2; 2e-16 (1 + b^2)^3 bounds it."""
    return 1e-9 + (2e-16 * (1.0 + beta * beta) ** 3 if beta < 0 else 0.0)


def main():
    ref_path = sys.argv[1] if len(sys.argv) > 1 else DEFAULT_REF
    ref = load_reference(ref_path)
    from scipy import special

    lines = [
        "# Reference values for tests/guided_pdfs.rs, written by tests/data/gen_guided_pdfs.py",
        "# from verify_guided_pdfs.py (numpy/scipy). Do not edit by hand; see the script's doc.",
    ]

    # ---- truncation masses ----
    for r in (0.5, 1.0, 2.0, 3.0, 4.0, 6.0):
        lines.append(f"mass,1,{fmt(r)},{fmt(special.erf(r / math.sqrt(2.0)))}")
        lines.append(f"mass,2,{fmt(r)},{fmt(-math.expm1(-0.5 * r * r))}")
        lines.append(f"mass,3,{fmt(r)},{fmt(ref.chi3_mass(r))}")

    # ---- 3D direction densities ----
    worst = 0.0
    worst_bound = 0.0
    betas = []
    n_dir = 0
    for label, x, mu, S, dirs in dir3_cases():
        A = np.linalg.inv(S)
        for r in (math.inf, 2.0, 3.0):
            inside = (x - mu) @ A @ (x - mu) <= r * r
            for k, w in enumerate(dirs):
                if math.isinf(r):
                    v = ref.pdf_dir_gauss(x, mu, S, w)[0]
                else:
                    v = ref.pdf_dir_gauss_trunc(x, mu, S, r, w)[0]
                _, beta, _ = ref._ray_quadratic(x, mu, S, np.atleast_2d(w))
                betas.append(float(beta[0]))
                hp = float(mp_dir_density(x, mu, S, w, r))
                if hp > 0 or v > 0:
                    err = abs(v - hp) / max(hp, 1e-300)
                    worst = max(worst, err)
                    if err > 1e-10:
                        print(f"note: {label} r={r} dir {k}: scipy {v:.17g} mpmath {hp:.17g} "
                              f"rel {err:.1e} beta {beta[0]:.2f}")
                    worst_bound = max(worst_bound, err / dir3_tolerance(beta[0]))
                side = "" if math.isinf(r) else ("-in" if inside else "-out")
                tag = f"{label}{side}#{k}"
                vals = [*x, *mu, S[0, 0], S[0, 1], S[0, 2], S[1, 1], S[1, 2], S[2, 2], *w,
                        beta[0], v, hp]
                lines.append(f"dir3,{tag},{fmt(r)}," + ",".join(fmt(t) for t in vals))
                n_dir += 1
    print(f"dir3: {n_dir} cases, beta in [{min(betas):.1f}, {max(betas):.1f}], "
          f"max rel diff scipy vs 50-digit closed form {worst:.1e} "
          f"({worst_bound:.2f} of the tolerance the Rust test uses)")

    # ---- plane variant (check 3 of verify_guided_pdfs.py), float32 inputs ----
    f32 = lambda v: np.asarray(v, dtype=np.float32).astype(np.float64)
    x = f32([0.1, -0.2, 0.0])
    g_prev = np.zeros(3)
    g = f32([0.4, 0.3, 2.0])
    F = f32(ref.frame((g - g_prev) / np.linalg.norm(g - g_prev)))  # rows u, v, n
    u, v, n = F
    C2 = np.array([[0.04, 0.015], [0.015, 0.01]])
    lam, E = np.linalg.eigh(C2)
    E = f32(E)
    sd = f32(np.sqrt(lam))
    m = np.array([0.05, -0.02])
    M2 = -math.expm1(-4.5)

    def q2_eigen(y):
        c = E.T @ (y - m)
        z2 = float(np.sum((c / sd) ** 2))
        if z2 > 9.0:
            return 0.0
        return math.exp(-0.5 * z2) / (2.0 * math.pi) / M2 / (sd[0] * sd[1])

    Ci = np.linalg.inv(C2)

    def q2_verify(y):  # verify_guided_pdfs.py's form, with the exact covariance
        d = y - m
        m2 = d @ Ci @ d
        if m2 > 9.0:
            return 0.0
        return math.exp(-0.5 * m2) / (2 * math.pi * math.sqrt(np.linalg.det(C2))) / M2

    def plane_pdf(w, q2):
        w = w / np.linalg.norm(w)
        cos = n @ w
        if cos == 0.0:
            return 0.0
        t = (n @ g - n @ x) / cos
        if not t > 0.0:
            return 0.0
        P = x + w * t - g
        y = np.array([P @ u, P @ v])
        return q2(y) * t * t / abs(cos)

    rng = np.random.default_rng(7)
    targets = []
    for radius in (0.0, 0.5, 1.0, 1.7, 2.4, 2.95, 3.05, 4.0):
        for _ in range(2 if radius > 0 else 1):
            phi = rng.uniform(0, 2 * math.pi)
            z = radius * np.array([math.cos(phi), math.sin(phi)])
            targets.append(m + E @ (sd * z))
    worst_plane = 0.0
    n_plane = 0
    for k, y in enumerate(targets):
        P = g + y[0] * u + y[1] * v
        for sign in (1.0, -1.0):  # -1: the plane is behind the origin, density 0
            w = f32(sign * (P - x))
            val = plane_pdf(w, q2_eigen)
            alt = plane_pdf(w, q2_verify)
            if val > 0:
                worst_plane = max(worst_plane, abs(val - alt) / val)
            vals = [*F[0], *F[1], *F[2], *g, *x, *w, *m, E[0, 0], E[0, 1], E[1, 0], E[1, 1],
                    *sd, val]
            lines.append(f"plane,p#{k}{'' if sign > 0 else '-behind'},"
                         + ",".join(fmt(t) for t in vals))
            n_plane += 1
    print(f"plane: {n_plane} cases, eigen form vs verify's inverse-covariance form (f32 "
          f"rounding of the kernel): max rel diff {worst_plane:.1e}")

    with open(OUT + ".tmp", "w") as fh:
        fh.write("\n".join(lines) + "\n")
    os.replace(OUT + ".tmp", OUT)
    print(f"wrote {OUT}: {len(lines) - 2} lines")


if __name__ == "__main__":
    main()
