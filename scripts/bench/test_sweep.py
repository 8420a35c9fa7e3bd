"""Tests of the equal-false-alarm comparison (score.py's choice of each peer's operating point, its
table) and of peers.py's sweeps. The score.py tests use the standard library only; the peers.py
tests are skipped where numpy, pysindy or sysidentpy are absent (CI does not install them).

    python -m pytest -q scripts/bench
"""
import json
import os
import random
import sys

import pytest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import score  # noqa: E402

CLEAN = 20


def sweep_record(per_index):
    """A peers.json sweep record from, per grid index, the (location, term, kind) items named."""
    items, path = [], []
    for named in per_index:
        idx = []
        for it in named:
            if list(it) not in items:
                items.append(list(it))
            idx.append(items.index(list(it)))
        path.append(idx)
    return {"items": items, "path": path, "seconds": 0.1, "cpu_seconds": 0.1}


def clean_flights(n, table_effects=None):
    return [{"id": "sim/clean_%d" % i, "suite": "sim", "planted": [],
             **({"table_effects": table_effects} if table_effects else {})} for i in range(n)]


SPUR = ("C_m", "β²", "CrossCoupling")


def records_with_counts(flights, counts):
    """Sweep records whose false alarms along a 5-value grid are `counts` (the first counts[i]
    clean flights name a spurious item at index i)."""
    return {f["id"]: sweep_record([[SPUR] if k < c else [] for c in counts]) for k, f in enumerate(flights)}


def test_operating_point_is_the_most_permissive_value_at_the_rate():
    fl = clean_flights(CLEAN)
    # 20 clean flights: at most 2 may have a false alarm; index 2 is the first with 2, index 3
    # (3 false alarms) comes after it and index 4 (none) is less permissive.
    recs = records_with_counts(fl, [20, 5, 2, 3, 0])
    assert score.operating_point(fl, recs, [1, 2, 3, 4, 5]) == (2, True, 2, CLEAN)


def test_operating_point_not_reached_reports_the_fewest():
    fl = clean_flights(CLEAN)
    recs = records_with_counts(fl, [20, 9, 4, 3, 3])
    # never <= 2: the fewest false alarms (3), the least permissive index on a tie
    assert score.operating_point(fl, recs, [1, 2, 3, 4, 5]) == (4, False, 3, CLEAN)


def test_operating_point_needs_clean_flights():
    planted = [{"id": "sim/x", "suite": "sim", "planted": [{"kind": "NonlinearAlpha", "location": "C_L"}]}]
    assert score.operating_point(planted, {"sim/x": sweep_record([[]])}, [1]) is None


def test_table_effects_are_not_false_alarms():
    table = [{"location": "C_D", "term": "|β|", "kind": "CrossCoupling", "terms": ["|β|"]}]
    fl = clean_flights(4, table)
    real = ("C_D", "|β|", "CrossCoupling")
    recs = {f["id"]: sweep_record([[real, SPUR], [real]]) for f in fl}
    # 4 clean flights: none may have a false alarm; naming the listed table effect is none
    assert score.operating_point(fl, recs, [1, 2]) == (1, True, 0, 4)


def test_vendored_jsbsim_lists_carry_the_side_force_of_the_beta_drag():
    """The drag's |β| term reaches the body side force as −C_D·sin β (odd in β): a β³ in C_Y on a
    clean c172x flight is a table effect, a β³ elsewhere or an α² in C_Y is not; the single
    flights' lists and the cards' agree."""
    root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tool", "data")
    flights = json.load(open(os.path.join(root, "jsbsim", "truth.json"), encoding="utf-8"))["flights"]
    cards = json.load(open(os.path.join(root, "jsbsim_card", "truth.json"), encoding="utf-8"))["table_effects"]
    for effects in [f["table_effects"] for f in flights.values()] + [cards]:
        assert effects == cards
        assert score.matches_table({"kind": "NonlinearBeta", "location": "C_Y", "what": "β³"}, effects)
        assert not score.matches_table({"kind": "NonlinearBeta", "location": "C_n", "what": "β³"}, effects)
        assert not score.matches_table({"kind": "NonlinearAlpha", "location": "C_Y", "what": "α²"}, effects)


def test_se_ratio_section_names_the_families_above_the_goal(tmp_path):
    """Two reports: C_L ΔV/V with ratios 1.0 and 2.0 (median 1.5, 90th percentile 2.0: above the
    goal), C_m α² with 0.9 and 1.1 (below); the summary names the first alone."""
    def cand(term, kind, r):
        return {"term": term, "kind": kind, "se_ratio": r}
    os.makedirs(tmp_path / "reports")
    fs = []
    for i, (a, b) in enumerate([(1.0, 0.9), (2.0, 1.1)]):
        rep = {"coefficients": [{"name": "C_L", "candidates": [cand("ΔV/V", "SpeedDependence", a)]},
                                {"name": "C_m", "candidates": [cand("α²", "NonlinearAlpha", b)]}],
               "compatibility": {"tested": []}}
        json.dump(rep, open(tmp_path / "reports" / ("sim_%d.json" % i), "w"))
        fs.append({"id": "sim/%d" % i})
    text = "\n".join(score.se_ratio_section("sim", fs, str(tmp_path)))
    assert "| C_L SpeedDependence | 2 | 1.50 | 2.00 | 2.00 | 50 % |" in text
    assert "above 1.5: 1 of 2: C_L SpeedDependence (2)" in text


def test_equal_fa_table_scores_the_chosen_point(tmp_path):
    """A suite of 20 clean flights and 4 planted ones: the peer's sweep names the plant on 4/4 at
    index 0 (with 6 clean flights alarmed), 2/4 at index 1 (1 clean flight alarmed: the rate is
    met) and nothing at index 2; the table must show index 1's figures."""
    plant = {"kind": "NonlinearAlpha", "location": "C_L", "terms": ["α²"]}
    hit = ("C_L", "α²", "NonlinearAlpha")
    fs = clean_flights(CLEAN)
    for k in range(4):
        fs.append({"id": "sim/lq_%d" % k, "suite": "sim", "planted": [plant]})
    for f in fs:
        f["aerosid"] = {"named": [{"kind": "NonlinearAlpha", "location": "C_L", "what": "α²"}] if f["planted"] else [],
                        "seconds": 0.1, "cpu_seconds": 0.1}
    recs = {}
    for k, f in enumerate(fs):
        if f["planted"]:
            recs[f["id"]] = sweep_record([[hit], [hit] if k < CLEAN + 2 else [], []])
        else:
            recs[f["id"]] = sweep_record([[SPUR] if k < 6 else [], [SPUR] if k < 1 else [], []])
    st = {"knob": "threshold", "grid": [0.1, 0.2, 0.4], "label": "peer"}
    pt = score.operating_point(fs, recs, st["grid"])
    assert pt == (1, True, 1, CLEAN)
    out = "\n".join(score.equal_fa_section("sim", fs, lambda f: f.get("aerosid"), [("peer", st, recs, pt)],
                                           str(tmp_path)))
    rows = {line.split(" | ")[0].lstrip("| "): line.split(" | ")[1:] for line in out.splitlines() if line.startswith("| ")}
    assert rows["operating point"][1].startswith("threshold 0.2")
    assert rows["planted aerodynamic effects named with the right cause"] == ["4/4", "2/4 |"]
    fa = [k for k in rows if k.startswith("clean flights with a false alarm")][0]
    assert rows[fa] == ["0/20", "1/20 |"]


def test_end_to_end_on_a_peers_file(tmp_path):
    """score.py's command line reads a peers file's sweeps and prints the equal-false-alarm table."""
    fs = clean_flights(10)
    for f in fs:
        f["aerosid"] = {"named": [], "seconds": 0.1}
    peers = {"schema": "aerosid-peers/3", "versions": {}, "settings": {},
             "sweeps": {"stlsq": {"peer": "stlsq", "knob": "threshold", "grid": [0.1, 1.0], "label": "STLSQ swept",
                                  "rule": "r"}},
             "flights": [{"id": f["id"], "suite": "sim", "peers": {},
                          "sweeps": {"stlsq": sweep_record([[SPUR], []])}} for f in fs]}
    (tmp_path / "manifest.json").write_text(json.dumps(fs))
    (tmp_path / "peers.json").write_text(json.dumps(peers))
    sys.argv = ["score.py", str(tmp_path / "manifest.json"), str(tmp_path / "peers.json"), "-o", str(tmp_path / "s.md")]
    score.main()
    text = (tmp_path / "s.md").read_text()
    assert "at an equal false-alarm rate" in text
    assert "| operating point | default (`--alpha 0.01 --gain-alpha 0.01`) | threshold 1 |" in text


# --- peers.py (needs numpy, pysindy, sysidentpy) ---------------------------------------------------

def regression(seed, n=600, p=6):
    np = pytest.importorskip("numpy")
    rng = np.random.default_rng(seed)
    X = rng.standard_normal((n, p))
    X[:, 3] += 0.8 * X[:, 0]  # correlated columns, as aerodynamic regressors are
    y = X @ np.array([1.0, -0.5, 0.2, 0.05, 0.0, 0.01]) + 0.3 * rng.standard_normal(n)
    return X, y


def test_stlsq_path_equals_a_fit_at_every_threshold():
    pytest.importorskip("pysindy")
    import numpy as np
    import peers
    grid = [float(v) for v in np.logspace(-3, 1, 33)]
    for seed in range(3):
        X, y = regression(seed)
        Xs, ys = peers.standardise(X, y, slice(0, len(y)))
        path = peers.stlsq_path(Xs, ys, grid)
        for th, c in zip(grid, path):
            # the shortcuts must give the library's own answer, to rounding
            assert np.allclose(c, peers.stlsq_fit(Xs, ys, th), rtol=1e-9, atol=1e-12)
        assert not np.any(path[-1])  # the grid's top names nothing on these columns


def test_frols_one_pass_equals_information_criterion():
    pytest.importorskip("sysidentpy")
    import warnings
    import numpy as np
    import peers
    X, y = regression(7)
    X = np.column_stack([np.ones(len(y)), X])
    m, Xi, yi, e_var, err, piv = peers.frols_prepare(X, y, len(y))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        iv = np.asarray(m.information_criterion(Xi, yi), dtype=float)
    sizes = np.arange(1, len(iv) + 1)
    # aic = N ln(e_var) + 2 k: the library's per-size residual variance
    assert np.allclose(np.exp((iv - 2 * sizes) / len(y)), e_var, rtol=1e-9)


def test_frols_penalty_sweep_is_monotone_and_ends_empty():
    pytest.importorskip("sysidentpy")
    import peers
    terms = ["1", "a", "b", "c", "d", "e", "f"]
    cands = terms[3:]
    rnd = random.Random(3)
    for seed in (rnd.randrange(1000) for _ in range(3)):
        X, y = regression(seed)
        import numpy as np
        X = np.column_stack([np.ones(len(y)), X])
        path = peers.sweep_named("frols-pen", X, y, len(y), terms, list(range(1, 7)), 3, None)
        counts = [len([t for t in sel if t in cands]) for sel in path]
        assert counts == sorted(counts, reverse=True)
        assert counts[-1] == 0
        assert all(sel[: len(sel)] == path[0][: len(sel)] for sel in path)  # nested: greedy order
