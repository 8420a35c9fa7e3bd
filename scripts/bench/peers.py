#!/usr/bin/env python3
"""Run the peer methods - pysindy's STLSQ and sysidentpy's FROLS - on the regression tables of a
benchmark manifest and write which candidate terms each names (peers.json).

    target/venv/bin/python scripts/bench/peers.py MANIFEST.json [-o peers.json] [--frols-ic aic]

Contract (scripts/bench/README.md): the manifest is a list of flights
  {"id", "suite", "table" (CSV relative to the manifest), "split" (rows before it = identification),
   "planted", "coefficients": {coef: {"baseline": [terms], "candidates": {term: kind}}}, "aerosid"?}
and the table's header is  t_s, z:<coef>..., x:<term>...  (every term of every coefficient).

For every flight and coefficient the peers see the same columns: baseline + candidates.
  STLSQ  pysindy.optimizers.STLSQ on standardised columns (z-scored with the identification rows'
         mean and std, y too, intercept by centring), ridge alpha = pysindy's default 0.05,
         unbias = True. Threshold: a fixed grid of 25 values, log-spaced 1e-3...1 (in standardised
         coefficient units); for each, fit on the identification rows and score the RMS error on
         the validation rows; the chosen threshold is the LARGEST (sparsest) whose validation MSE is
         within 1 % of the grid's best - the same rule for every flight and coefficient.
  FROLS  sysidentpy.model_structure_selection.FROLS used as a static regression: its own
         information_criterion() (AIC by default) over 1..n terms of its ERR forward orthogonal
         selection, then error_reduction_ratio() with the chosen size and LeastSquares - the
         library's routines, called on the given regressor matrix (no lags: max_lag = 0), because
         FROLS.fit() builds its own NARX polynomial basis from lagged inputs and cannot take
         arbitrary columns. The identification rows only (FROLS's order selection is in-sample).
Named terms = candidates (not baseline terms) with a nonzero coefficient in the final model.
"""
import argparse
import json
import os
import sys
import time
import warnings

import numpy as np


def load_table(path):
    with open(path) as f:
        header = f.readline().strip().split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return header, data


def standardise(X, y, ident):
    mx = X[ident].mean(axis=0)
    sx = X[ident].std(axis=0)
    sx[sx == 0] = 1.0
    my = y[ident].mean()
    sy = y[ident].std() or 1.0
    return (X - mx) / sx, (y - my) / sy


THRESHOLDS = np.logspace(-3, 0, 25)


def run_stlsq(X, y, n_ident, terms):
    """X without the constant column (centring replaces it). Returns the selected term names."""
    from pysindy.optimizers import STLSQ
    ident = slice(0, n_ident)
    valid = slice(n_ident, None)
    Xs, ys = standardise(X, y, ident)
    has_valid = Xs[valid].shape[0] > 10
    results = []
    for th in THRESHOLDS:
        opt = STLSQ(threshold=float(th))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            opt.fit(Xs[ident], ys[ident].reshape(-1, 1))
        coef = np.asarray(opt.coef_).ravel()
        if has_valid:
            mse = float(np.mean((ys[valid] - Xs[valid] @ coef) ** 2))
        else:  # no validation rows: in-sample error (documented fallback)
            mse = float(np.mean((ys[ident] - Xs[ident] @ coef) ** 2))
        results.append((th, mse, coef))
    best = min(r[1] for r in results)
    chosen = max((r for r in results if r[1] <= 1.01 * best), key=lambda r: r[0])
    sel = [terms[i] for i in np.flatnonzero(chosen[2] != 0)]
    return sel, float(chosen[0])


def run_frols(X, y, n_ident, terms, ic):
    from sysidentpy.model_structure_selection import FROLS
    from sysidentpy.parameter_estimation import LeastSquares
    Xi = X[:n_ident]
    yi = y[:n_ident].reshape(-1, 1)
    # Scale columns to unit RMS (ERR is scale-invariant; this only helps the conditioning).
    sc = np.sqrt(np.mean(Xi**2, axis=0))
    sc[sc == 0] = 1.0
    Xi = Xi / sc
    m = FROLS(order_selection=True, info_criteria=ic, n_info_values=Xi.shape[1], estimator=LeastSquares(),
              ylag=1, xlag=1)
    m.max_lag = 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        iv = m.information_criterion(Xi, yi)
        n = int(np.nanargmin(iv)) + 1
        err, piv, psi = m.error_reduction_ratio(Xi, yi, n)
        theta = LeastSquares().optimize(psi, yi).ravel()
    sel = [terms[int(piv[k])] for k in range(n) if theta[k] != 0]
    return sel, n


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("manifest")
    ap.add_argument("-o", "--out", default=None, help="default: peers.json next to the manifest")
    ap.add_argument("--frols-ic", default="aic", help="FROLS info_criteria: aic (default), aicc, bic, fpe, lilc")
    a = ap.parse_args()
    import pysindy
    import sysidentpy
    base = os.path.dirname(os.path.abspath(a.manifest))
    flights = json.load(open(a.manifest))
    out = {"schema": "aerosid-peers/1",
           "versions": {"python": sys.version.split()[0], "numpy": np.__version__,
                        "pysindy": pysindy.__version__, "sysidentpy": sysidentpy.__version__},
           "settings": {"stlsq": {"thresholds": [float(t) for t in THRESHOLDS], "alpha": 0.05, "unbias": True,
                                  "rule": "largest threshold with validation MSE <= 1.01 x best, standardised columns"},
                        "frols": {"info_criteria": a.frols_ic, "estimator": "LeastSquares",
                                  "rows": "identification", "lags": 0}},
           "flights": []}
    for fl in flights:
        header, data = load_table(os.path.join(base, fl["table"]))
        col = {h: i for i, h in enumerate(header)}
        n_ident = int(fl["split"])
        rec = {"id": fl["id"], "suite": fl.get("suite"), "peers": {}}
        details = {"stlsq": {}, "frols": {}}
        named = {"stlsq": [], "frols": []}
        secs = {"stlsq": 0.0, "frols": 0.0}
        for coef, spec in fl["coefficients"].items():
            zname = "z:" + coef
            if zname not in col:
                continue
            cands = spec.get("candidates", {})
            terms = [t for t in list(spec["baseline"]) + list(cands) if "x:" + t in col]
            y = data[:, col[zname]]
            X = np.column_stack([data[:, col["x:" + t]] for t in terms])
            ok = np.isfinite(y) & np.all(np.isfinite(X), axis=1)
            if not ok.all():  # rows with NaN are dropped; the split counts original rows
                n_id = int(ok[:n_ident].sum())
                X, y = X[ok], y[ok]
            else:
                n_id = n_ident
            # STLSQ: the constant column is replaced by centring.
            nc = [i for i, t in enumerate(terms) if np.ptp(X[:n_id, i]) > 0]
            t0 = time.perf_counter()
            sel, th = run_stlsq(X[:, nc], y, n_id, [terms[i] for i in nc])
            secs["stlsq"] += time.perf_counter() - t0
            details["stlsq"][coef] = {"selected": sel, "threshold": th}
            named["stlsq"] += [{"location": coef, "term": t, "kind": cands[t]} for t in sel if t in cands]
            t0 = time.perf_counter()
            sel, n = run_frols(X, y, n_id, terms, a.frols_ic)
            secs["frols"] += time.perf_counter() - t0
            details["frols"][coef] = {"selected": sel, "n_terms": n}
            named["frols"] += [{"location": coef, "term": t, "kind": cands[t]} for t in sel if t in cands]
        for p in ("stlsq", "frols"):
            rec["peers"][p] = {"named": named[p], "seconds": round(secs[p], 4), "fits": details[p]}
        out["flights"].append(rec)
        print("%-22s STLSQ %2d named (%.2f s)  FROLS %2d named (%.2f s)" % (
            fl["id"], len(named["stlsq"]), secs["stlsq"], len(named["frols"]), secs["frols"]))
    path = a.out or os.path.join(base, "peers.json")
    json.dump(out, open(path, "w"), indent=1, ensure_ascii=False)
    print("wrote", path)


if __name__ == "__main__":
    main()
