"""A numpy/scipy reference of lab's modular Kennedy-O'Hagan calibration (paper Appendix, A1-A9).

Written independently of lab's Rust code from the same equations and the same choices, on the same
emulator design (read from the JSON that benches/koh_reference.rs writes):

- emulator: GP over (design, parameters), inputs through ln and scaled to the unit cube, output ln y
  standardised, quadratic trend, Gaussian kernel, nugget 1e-8, beta and sigma^2 by GLS, roughness by
  maximum likelihood (scipy L-BFGS-B on ln roughness in [-4.6, 6.2], several starts);
- tests: y ~ N(mu_emu + beta_d, Sigma_emu + sigma_d^2 C(lambda_d) + jitter I), beta_d profiled (ML)
  or integrated out under a flat prior (posterior); sigma_d from 1e-3 s to 3 s, lambda_d in [0.1, 100],
  uniform priors on theta, ln sigma_d^2 and ln lambda_d;
- theta-hat by L-BFGS-B from ten starts, then a bounded 1-D polish in theta;
- posterior of theta by brute force: a dense tensor grid in the hyperparameters (Gauss-Legendre) and a
  graded grid in theta (uniform plus geometric towards theta-hat, where two tests make a cusp),
  trapezoid rule, quantiles by interpolating the cumulative sum.

Run with single-threaded BLAS: OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1.
Usage: python koh_reference.py INPUT.json [REPEATS]; prints a JSON line.
"""

import json
import sys
import time

import numpy as np
from scipy.optimize import minimize, minimize_scalar

NUGGET = 1e-8
LOG_ROUGH = (-4.6, 6.2)


def unit_inputs(x, lo, hi):
    # lab picks ln x or x by likelihood over ranges wider than a decade; the cases here are narrower.
    log = lo > 0
    lo_w = np.where(log, np.log(np.where(log, lo, 1.0)), lo)
    hi_w = np.where(log, np.log(np.where(log, hi, 1.0)), hi)
    xw = np.where(log, np.log(np.where(log, x, 1.0)), x)
    return (xw - lo_w) / (hi_w - lo_w)


def corr(a, b, rough):
    d2 = ((a[:, None, :] - b[None, :, :]) ** 2 * rough).sum(axis=2)
    return np.exp(-d2)


def basis(x):
    n, p = x.shape
    cols = [np.ones(n)] + [x[:, i] for i in range(p)]
    cols += [x[:, i] * x[:, j] for i in range(p) for j in range(i, p)]
    return np.column_stack(cols)


def gls(x, z, f, rough):
    n = len(z)
    r = corr(x, x, rough) + NUGGET * np.eye(n)
    l = np.linalg.cholesky(r)
    lf = np.linalg.solve(l, f)  # triangular, small: a plain solve is fine here
    lz = np.linalg.solve(l, z)
    a = lf.T @ lf + 1e-12 * np.eye(f.shape[1])
    beta = np.linalg.solve(a, lf.T @ lz)
    e = lz - lf @ beta
    s2 = e @ e / n
    nll = 0.5 * n * np.log(max(s2, 1e-300)) + np.log(np.diag(l)).sum()
    return nll, dict(l=l, lf=lf, la=np.linalg.cholesky(a), beta=beta, s2=s2,
                     alpha=np.linalg.solve(r, z - f @ beta))


class Emulator:
    def __init__(self, x_raw, y, lo, hi):
        self.lo, self.hi = lo, hi
        self.x = unit_inputs(x_raw, lo, hi)
        t = np.log(y)
        self.t_mean, self.t_sd = t.mean(), t.std()
        self.z = (t - self.t_mean) / self.t_sd
        self.f = basis(self.x)
        p = self.x.shape[1]

        def cost(v):
            return gls(self.x, self.z, self.f, np.exp(v))[0]

        best = None
        for s in np.linspace(0.1, 0.9, 6):
            start = np.full(p, LOG_ROUGH[0] + s * (LOG_ROUGH[1] - LOG_ROUGH[0]))
            start[1::2] = LOG_ROUGH[1] - s * (LOG_ROUGH[1] - LOG_ROUGH[0])
            res = minimize(cost, start, method="L-BFGS-B", bounds=[LOG_ROUGH] * p)
            if best is None or res.fun < best.fun:
                best = res
        self.rough = np.exp(best.x)
        self.nll, self.g = gls(self.x, self.z, self.f, self.rough)

    def mean_cov(self, pts):
        u = unit_inputs(pts, self.lo, self.hi)
        g = self.g
        r = corr(self.x, u, self.rough)
        fs = basis(u)
        zm = fs @ g["beta"] + r.T @ g["alpha"]
        w = np.linalg.solve(g["l"], r)
        h = np.linalg.solve(g["la"], fs.T - g["lf"].T @ w)
        c = corr(u, u, self.rough) - w.T @ w + h.T @ h
        y = np.exp(self.t_mean + self.t_sd * zm)
        cov = c * g["s2"] * self.t_sd ** 2 * np.outer(y, y)
        return y, cov


class Koh:
    def __init__(self, emu, designs, measured, d_lo, d_hi, th_lo, th_hi):
        self.emu, self.d, self.y = emu, designs, measured
        self.ud = (designs - d_lo) / (d_hi - d_lo)
        self.th_lo, self.th_w = th_lo, th_hi - th_lo
        r = measured - self.mu_cov(th_lo + 0.5 * self.th_w)[0]
        s = max(np.sqrt(np.mean(r ** 2)), 1e-3 * np.sqrt(np.mean(measured ** 2)))
        self.log_var = (np.log((1e-3 * s) ** 2), np.log((3 * s) ** 2))
        self.log_rough = (np.log(0.1), np.log(100.0))
        self.jitter = 1e-10 * s * s
        self.p = len(th_lo)

    def mu_cov(self, theta):
        pts = np.column_stack([self.d, np.tile(theta, (len(self.d), 1))])
        return self.emu.mean_cov(pts)

    def nll(self, u, marginal):
        """The tests' negative log-likelihood at unit-box point u = (theta, ln var, ln lambda...)."""
        p = self.p
        mu, cov = self.mu_cov(self.th_lo + u[:p] * self.th_w)
        var = np.exp(self.log_var[0] + u[p] * (self.log_var[1] - self.log_var[0]))
        rough = np.exp(self.log_rough[0] + u[p + 1:] * (self.log_rough[1] - self.log_rough[0]))
        v = cov + var * corr(self.ud, self.ud, rough) + self.jitter * np.eye(len(mu))
        return self.nll_of(v, self.y - mu, marginal)

    @staticmethod
    def nll_of(v, r, marginal):
        """v: (..., m, m) covariances, r: (m,) residual: log det L + e'e/2 (+ ln a / 2)."""
        try:
            l = np.linalg.cholesky(v)
        except np.linalg.LinAlgError:
            return np.inf
        m = r.shape[-1]
        lr = np.linalg.solve(l, np.broadcast_to(r, v.shape[:-1])[..., None])[..., 0]
        l1 = np.linalg.solve(l, np.ones(v.shape[:-1])[..., None])[..., 0]
        a = (l1 * l1).sum(-1)
        b = (l1 * lr).sum(-1)
        e2 = (lr * lr).sum(-1) - b * b / a
        out = np.log(np.diagonal(l, axis1=-2, axis2=-1)).sum(-1) + 0.5 * e2
        return out + 0.5 * np.log(a) if marginal else out

    def fit_ml(self):
        dim = self.p + 1 + self.ud.shape[1]
        rng = np.random.default_rng(1)
        best = None
        for _ in range(10):
            res = minimize(lambda u: self.nll(u, False), rng.uniform(size=dim),
                           method="L-BFGS-B", bounds=[(0, 1)] * dim)
            if best is None or res.fun < best.fun:
                best = res
        u = best.x.copy()
        for k in range(self.p):  # polish theta at the found hyperparameters
            def line(t, k=k):
                v = u.copy()
                v[k] = t
                return self.nll(v, False)
            grid = np.linspace(0, 1, 41)
            i = int(np.argmin([line(t) for t in grid]))
            res = minimize_scalar(line, bounds=(grid[max(i - 1, 0)], grid[min(i + 1, 40)]),
                                  method="bounded", options={"xatol": 1e-10})
            if res.fun <= line(u[k]):
                u[k] = res.x
        return u

    def log_density(self, t, hyper_nodes, hyper_w, corrs, variances):
        mu, cov = self.mu_cov(self.th_lo + t * self.th_w)
        m = len(mu)
        v = cov[None] + variances[:, None, None] * corrs + self.jitter * np.eye(m)[None]
        nll = self.nll_of(v, self.y - mu, True)
        lo = nll.min()
        return np.log((hyper_w * np.exp(lo - nll)).sum()) - lo

    def posterior(self, u_hat, n_var=64, n_rough=24, n_theta=1500):
        """1-D theta posterior (one parameter, one design variable) by brute-force grids."""
        gx, gw = np.polynomial.legendre.leggauss(n_var)
        rx, rw = np.polynomial.legendre.leggauss(n_rough)
        uv, wv = (gx + 1) / 2, gw / 2
        ur, wr = (rx + 1) / 2, rw / 2
        var = np.exp(self.log_var[0] + uv * (self.log_var[1] - self.log_var[0]))
        rough = np.exp(self.log_rough[0] + ur * (self.log_rough[1] - self.log_rough[0]))
        corrs_r = np.stack([corr(self.ud, self.ud, np.array([lam])) for lam in rough])
        variances = np.repeat(var[None, :], n_rough, axis=0).ravel()
        corrs = np.repeat(corrs_r, n_var, axis=0)
        w = (wr[:, None] * wv[None, :]).ravel()
        th = u_hat[0]
        dist = np.logspace(-10, 0, n_theta)
        ts = np.concatenate([np.linspace(0, 1, n_theta), th - dist, th + dist, [th]])
        ts = np.unique(ts[(ts >= 0) & (ts <= 1)])
        logd = np.array([self.log_density(t, None, w, corrs, variances) for t in ts])
        d = np.exp(logd - logd.max())
        cdf = np.concatenate([[0], np.cumsum(0.5 * (d[1:] + d[:-1]) * np.diff(ts))])
        cdf /= cdf[-1]
        q = lambda p: self.th_lo[0] + np.interp(p, cdf, ts) * self.th_w[0]
        return q(0.5), (q(0.025), q(0.975)), len(ts) * len(w)


def calibrate(data, parts):
    t0 = time.perf_counter()
    x = np.array(data["inputs"])
    emu = Emulator(x, np.array(data["outputs"]), np.array(data["lower"]), np.array(data["upper"]))
    t1 = time.perf_counter()
    pd = len(data["design_lower"])
    koh = Koh(emu, np.array(data["designs"]), np.array(data["measured"]),
              np.array(data["design_lower"]), np.array(data["design_upper"]),
              np.array(data["lower"][pd:]), np.array(data["upper"][pd:]))
    u = koh.fit_ml()
    t2 = time.perf_counter()
    median, interval, evals = koh.posterior(u)
    parts.append([t1 - t0, t2 - t1, time.perf_counter() - t2])
    theta = koh.th_lo + u[:koh.p] * koh.th_w
    return emu, theta, median, interval, evals


def main():
    data = json.load(open(sys.argv[1]))
    repeats = int(sys.argv[2]) if len(sys.argv) > 2 else 3
    times, parts = [], []
    for _ in range(repeats):
        t0 = time.perf_counter()
        emu, theta, median, interval, evals = calibrate(data, parts)
        times.append(time.perf_counter() - t0)
    # The emulator's optimum against lab's roughness on the same likelihood.
    lab_nll = gls(emu.x, emu.z, emu.f, np.array(data["lab_roughness"]))[0]
    print(json.dumps({
        "seconds": sorted(times)[len(times) // 2],
        "seconds_emulator_ml_posterior": [float(np.median([p[k] for p in parts])) for k in range(3)],
        "theta": theta.tolist(), "median": median, "interval95": list(interval),
        "roughness": emu.rough.tolist(), "emulator_nll": emu.nll, "emulator_nll_at_lab_roughness": lab_nll,
        "posterior_evaluations": int(evals),
    }))


if __name__ == "__main__":
    main()
