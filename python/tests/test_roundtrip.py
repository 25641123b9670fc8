"""The fit JSON both ways, the data set's arrays, and simulate against known truths."""

import math

import numpy as np
import pytest

import brdfit


@pytest.fixture(scope="module")
def fits(root):
    return brdfit.fit_all(brdfit.load(root / "data" / "merl-alumina-oxide.csv", channel="g"), verify=2)


def test_to_json_from_json_round_trip(fits):
    for r in fits:
        back = brdfit.FitResult.from_json(r.to_json())
        assert back.to_json() == r.to_json()
        assert back.params == r.params and back.stderr == r.stderr
        assert back.ranges == r.ranges and back.flags == r.flags and back.usable == r.usable
        assert back.bic == r.bic
        np.testing.assert_array_equal(back.correlation, r.correlation)
    text = brdfit.to_json(fits)
    again = brdfit.read_fits(text)
    assert [f.label for f in again] == [f.label for f in fits]
    assert brdfit.to_json(again) == text
    with pytest.raises(brdfit.BrdfitError, match="read_fits"):
        brdfit.FitResult.from_json(text)


def test_result_fields(fits):
    """Fields in the model's order, a correlation matrix of ones on its diagonal, one result
    per model of fit --model all."""
    assert [(f.model, f.distribution) for f in fits] == brdfit.model_names()
    ts = next(f for f in fits if f.label == "torrance-sparrow (d3)")
    assert list(ts.params) == ["n", "c3", "ps", "pd"] == list(ts.stderr)
    c = ts.correlation
    assert c.shape == (4, 4)
    np.testing.assert_allclose(np.diag(c), 1.0)
    np.testing.assert_allclose(c, c.T)
    assert ts.verified is True and ts.usable
    lo, hi = ts.intervals["n"]
    assert lo < ts.params["n"] < hi and ts.interval_level == 0.95 and ts.ranges == ts.intervals


def test_dataset_arrays(root):
    """The arrays of a CSV file: radians, values per channel, as the file writes them."""
    path = root / "data" / "merl-aluminium.csv"
    d = brdfit.load(path)
    rows = [l for l in path.read_text().splitlines() if not l.startswith("#")]
    head = rows[0].split(",")
    first = [float(x) for x in rows[1].split(",")]
    assert d.channels == ["r", "g", "b"] and len(d) == len(rows) - 1
    assert d.values.shape == (len(d), 3) and d.directions.shape == (len(d), 4)
    assert d.theta_i[0] == math.radians(first[head.index("theta_i_deg")])
    assert list(d.values[0]) == [first[head.index(f"brdf_{c}")] for c in "rgb"]
    assert d.values.dtype == np.float64


def test_simulate_matches_eval_and_noise_is_seeded():
    """Without noise a simulation is the model's f_r at the grid; noise is seeded."""
    p = {"n": 1.8, "c3": 0.35, "ps": 0.667, "pd": 0.333}
    d = brdfit.simulate("torrance-sparrow", p, grid="hemisphere:2000", seed=3)
    np.testing.assert_array_equal(d.values[:, 0], brdfit.eval("torrance-sparrow", p, d.directions))
    a = brdfit.simulate("torrance-sparrow", p, grid="hemisphere:2000", noise=0.01, seed=3)
    b = brdfit.simulate("torrance-sparrow", p, grid="hemisphere:2000", noise=0.01, seed=3)
    np.testing.assert_array_equal(a.values, b.values)
    rel = a.values[:, 0] / d.values[:, 0] - 1
    assert 0.008 < rel.std() < 0.012


def test_fit_recovers_truth():
    """A known truth: Blinn's MgO sampled on 10,000 directions with 1 % noise is fitted back
    within 2 % of each value, verified by random starts."""
    p = {"n": 1.8, "c3": 0.35, "ps": 0.667, "pd": 0.333}
    r = brdfit.fit(brdfit.simulate("torrance-sparrow", p, grid="hemisphere:10000", noise=0.01, seed=5), verify=2)
    assert r.usable and r.verified
    for k, v in p.items():
        assert abs(r.params[k] / v - 1) < 0.02, (k, r.params[k], r.ranges[k])


def test_nbrdf_goniometer(root):
    """A network of the bundled weights on the goniometer grid: 16,512 RGB samples, the same as
    the command line's simulate writes (checked against its CSV in test_cli_peer)."""
    w = root / "tests" / "data" / "nbrdf" / "weights-merl8.json"
    names = brdfit.nbrdf_materials(w)
    assert len(names) == 8
    d = brdfit.simulate(nbrdf=w, material=names[0], grid="goniometer")
    assert len(d) == 16512 and d.channels == ["r", "g", "b"]
    assert np.all(np.isfinite(d.values)) and np.all(d.values >= 0)


def test_export_mitsuba(fits):
    xml = brdfit.export(fits, to="mitsuba")
    assert "<bsdf" in xml


def test_simulate_at_directions_in_any_layout():
    """Directions given in C order, Fortran order or strided: the same samples, f_r as eval's."""
    p = {"alpha": 0.3, "n": 1.5, "ps": 0.8, "pd": 0.2}
    rng = np.random.default_rng(4)
    d = np.column_stack([rng.uniform(0, 1.5, 300), np.zeros(300), rng.uniform(0, 1.5, 300), rng.uniform(-3, 3, 300)])
    expected = brdfit.eval("ggx-smith", p, d)
    for dirs in (d, np.asfortranarray(d), np.repeat(d, 2, axis=0)[::2]):
        s = brdfit.simulate("ggx-smith", p, directions=dirs)
        np.testing.assert_array_equal(s.values[:, 0], expected)
        np.testing.assert_array_equal(s.directions, d)
