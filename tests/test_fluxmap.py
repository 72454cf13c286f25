"""Flux maps from files: CSV and SyR-e .mat read, resampled to an even
grid, completed by symmetry, checked against the current limit and
[electrical], and run by the plant from a machine file's [magnetic] file."""
import tomllib
import warnings

import numpy as np
import pytest

from fullspeed.model.errors import ConfigError
from fullspeed.model.fluxmap import FluxMapWarning, load_map, zero_current_values
from fullspeed.design.machine import load_machine
from fullspeed.design.scenario import load_scenario, scenario_from_dict
from fullspeed.sim import simulate

PSI_F, L_D, L_Q = 0.0105, 0.30e-3, 0.55e-3        # a 48 V IPMSM of the trial's kind
I_D = np.array([-45.0, -30.0, -20.0, -10.0, 0.0, 10.0, 25.0])   # uneven, as FEA grids often are
I_Q = np.array([0.0, 10.0, 20.0, 30.0, 45.0])                   # i_q >= 0 only, as SyR-e maps


def psi(i_d, i_q, scale=1.0, i_sat=30.0):
    """Linear in i_d, odd and saturating in i_q (bilinear resampling is exact in i_d)."""
    return scale * (PSI_F + L_D * i_d), L_Q * i_sat * np.tanh(i_q / i_sat)


def write_csv(path, i_d=I_D, i_q=I_Q, scale=1.0, torque_p=4, header="i_d [A],i_q [A],psi_d [mWb],psi_q [Wb],T [N m]",
              i_sat=30.0):
    lines = ["# FEA export, 2D, 20 C", header]
    for a in i_d:
        for b in i_q:
            pd, pq = psi(a, b, scale, i_sat)
            T = 1.5 * torque_p * (pd * b - pq * a)
            lines.append(f"{a},{b},{pd * 1e3:.9g},{pq:.9g},{T:.9g}")
    path.write_text("\n".join(lines) + "\n")
    return path


MACHINE = '''name = "my-48v"
kind = "ipmsm"
pole_pairs = 4
[electrical]
R_s = 0.025
L_d = 0.30e-3
L_q = 0.55e-3
psi_f = 0.0105
[mechanical]
J = 5e-4
[rated]
torque = 3.0
current = 28.0
speed_rpm = 3000.0
[magnetic]
file = "map.csv"
[bench]
u_dc = 48.0
f_pwm = 20000.0
i_max = {i_max}
i_trip = 52.0
adc_range = 60.0
bw_current = 6000.0
bw_speed = 150.0
bw_pll = 600.0
'''


def test_csv_is_read_in_si_resampled_evenly_and_completed_by_symmetry(tmp_path):
    mag = load_map(write_csv(tmp_path / "map.csv"), "magnetic.file")
    i_d, i_q = np.array(mag["i_d"]), np.array(mag["i_q"])
    assert np.allclose(np.diff(i_d), np.diff(i_d)[0]) and np.allclose(np.diff(i_q), np.diff(i_q)[0])
    assert (i_d[0], i_d[-1], i_q[0], i_q[-1]) == (-45.0, 25.0, -45.0, 45.0) and i_d.size == 7 and i_q.size == 9
    D, Q = np.meshgrid(i_d, i_q, indexing="ij")
    pd, _ = psi(D, Q)
    assert np.allclose(mag["psi_d"], pd, atol=1e-12)                   # mWb read as 1e-3 Wb; exact where linear
    assert np.allclose(np.array(mag["psi_q"])[:, 0], -np.array(mag["psi_q"])[:, -1])   # odd in i_q
    assert np.allclose(np.array(mag["torque"])[:, 0], -np.array(mag["torque"])[:, -1])
    assert "negative i_q by symmetry" in mag["source"] and "resampled" in mag["source"] and "sha256" in mag["source"]
    z = zero_current_values(mag)
    assert z["psi_f"] == pytest.approx(PSI_F) and z["L_d"] == pytest.approx(L_D)


@pytest.mark.parametrize("header, what", [
    ("i_d [A],i_q [A],psi_d,psi_q [Wb]", "needs its unit"),
    ("i_d [A],i_q [A],psi_d [T],psi_q [Wb]", "unit must be one of"),
    ("i_d [A],i_q [A],psi_q [Wb],T [N m],x [1]", "has no column psi_d"),
])
def test_a_header_without_units_or_columns_is_refused(tmp_path, header, what):
    with pytest.raises(ConfigError, match=what):
        load_map(write_csv(tmp_path / "map.csv", header=header), "magnetic.file")


def test_a_map_that_does_not_reach_the_current_limit_is_refused(tmp_path):
    write_csv(tmp_path / "map.csv", i_d=np.array([-10.0, 0.0, 10.0]), i_q=np.array([0.0, 5.0, 10.0]))
    (tmp_path / "m.toml").write_text(MACHINE.format(i_max=40.0))
    with pytest.raises(ConfigError, match=r"machine.magnetic.i_q = '-10..10 A': must cover \+-i_max = \+-40 A"):
        load_machine(tmp_path / "m.toml")


def test_a_map_with_twice_the_flux_gets_one_warning_line(tmp_path):
    write_csv(tmp_path / "map.csv", scale=2.0)
    (tmp_path / "m.toml").write_text(MACHINE.format(i_max=40.0).replace("i_max = 40.0", "i_max = 25.0"))
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        load_machine(tmp_path / "m.toml")
    lines = [str(x.message) for x in w if issubclass(x.category, FluxMapWarning)]
    assert len(lines) == 1 and "\n" not in lines[0]
    assert "psi_f 0.0105 Wb, map 0.021" in lines[0] and "L_d" in lines[0] and "L_q" not in lines[0]
    write_csv(tmp_path / "map.csv")
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        load_machine(tmp_path / "m.toml")
    assert not [x for x in w if issubclass(x.category, FluxMapWarning)]     # the consistent map: silent


def test_syre_mat_is_turned_to_the_pmsm_convention(tmp_path):
    sio = pytest.importorskip("scipy.io")
    # SyR-e: magnet on -q. Id_syre = i_q, Iq_syre = -i_d, Fd = psi_q, Fq = -psi_d
    Q, D = np.meshgrid(I_Q, I_D[::-1] * -1, indexing="xy")   # any layout of full matrices
    i_d, i_q = -D, Q
    pd, pq = psi(i_d, i_q)
    fm = {"Id": i_q, "Iq": -i_d, "Fd": pq, "Fq": -pd, "T": 1.5 * 4 * (pd * i_q - pq * i_d)}
    sio.savemat(tmp_path / "syre.mat", {"motorModel": {"FluxMap_dq": fm}})
    mag = load_map(tmp_path / "syre.mat", "magnetic.file")
    z = zero_current_values(mag)
    assert z["psi_f"] == pytest.approx(PSI_F) and z["L_d"] == pytest.approx(L_D)
    assert mag["i_q"][0] == -45.0 and mag["i_d"][0] == -45.0


def test_a_machine_file_with_its_map_runs_on_the_map(tmp_path):
    """The plant follows the file: at zero current its d flux is the map's."""
    write_csv(tmp_path / "map.csv")
    (tmp_path / "m.toml").write_text(MACHINE.format(i_max=40.0))
    machine = tomllib.loads(MACHINE.format(i_max=40.0))     # inline, the map beside the scenario
    sc = scenario_from_dict({"name": "s", "duration": 0.2, "machine": machine, "controller": {"mode": "speed"},
                             "references": {"speed_rpm": [[0.0, 0.0], [0.02, 0.0], [0.02, 1000.0]]}},
                            str(tmp_path / "s.toml"))
    assert sc.machine.magnetic["model"] == "fluxmap" and sc.machine.magnetic["source"].startswith("map.csv")
    res = simulate(sc)
    assert res.stop_reason == "done"
    assert res["psi_d"][0] == pytest.approx(PSI_F, rel=1e-6)
    assert abs(res.metrics["speed_error_pct"]) < 1.0


def test_the_controller_takes_its_tables_from_the_map(tmp_path):
    """On the synthetic map (psi_d linear, psi_q = 30 L_q tanh(i_q / 30)):
    psi_f, the secant L_q at the rated MTPA point, the incremental L_q the
    carrier sees at half rated current, and an MTPA locus that gives more
    torque per ampere on the map than the linear model's locus does."""
    from fullspeed.design.magnetics import controller_values, mtpa_locus
    from fullspeed.model.fluxmap import interp
    mag = load_map(write_csv(tmp_path / "map.csv"), "magnetic.file")
    cv = controller_values(mag, 40.0, 28.0, 3, 4)
    assert cv["psi_f"] == pytest.approx(PSI_F) and cv["L_d"] == pytest.approx(L_D, rel=1e-6)
    I = 40.0 * np.arange(64) / 63
    q_r, q_h = np.interp(28.0, I, cv["mtpa_i_q"]), np.interp(14.0, I, cv["mtpa_i_q"])
    # the map is coarse (11.25 A steps after resampling): within 5 % of the function it samples
    assert cv["L_q"] == pytest.approx(L_Q * 30 * np.tanh(q_r / 30) / q_r, rel=0.05)      # secant
    assert cv["L_q_hf"] == pytest.approx(L_Q / np.cosh(q_h / 30) ** 2, rel=0.05)         # incremental
    T, d, q = mtpa_locus(mag, 40.0, 3, 4)
    assert np.all(np.diff(T) > 0) and np.allclose(np.hypot(d, q), I)
    # the linear model's locus (fs_mtpa.h) at 40 A, on the map's fluxes
    dL = L_Q - L_D
    d_lin = (PSI_F - np.sqrt(PSI_F ** 2 + 8 * dL ** 2 * 40.0 ** 2)) / (4 * dL)
    q_lin = np.sqrt(40.0 ** 2 - d_lin ** 2)
    T_lin = 6 * (interp(mag, "psi_d", d_lin, q_lin) * q_lin - interp(mag, "psi_q", d_lin, q_lin) * d_lin)
    assert T[-1] > T_lin * 1.005


def test_a_map_whose_saliency_vanishes_under_load_says_how_much_torque_injection_can_hold(tmp_path):
    """The incremental L_q = L_Q / cosh^2(i_q / i_sat) falls to L_D at
    i_q = i_sat acosh(sqrt(L_Q / L_D)): 23.1 A with i_sat = 20 A, where the
    injection has no axis left; with i_sat = 200 A it never gets there."""
    from fullspeed.design.magnetics import saliency_warnings
    i_q = np.array([0.0, 5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 45.0])
    mag = load_map(write_csv(tmp_path / "a.csv", i_q=i_q, i_sat=20.0), "magnetic.file")
    (line,) = saliency_warnings(mag, 40.0, 3, 4, 5.0, "m")
    i_cross = 20.0 * np.arccosh(np.sqrt(L_Q / L_D))
    I = float(line.split(" N m (")[1].split(" A")[0])
    assert i_cross * 0.8 < I < i_cross * 1.3        # on the locus, on a map of 5 A steps
    mild = load_map(write_csv(tmp_path / "b.csv", i_q=i_q, i_sat=200.0), "magnetic.file")
    assert saliency_warnings(mild, 40.0, 3, 4, 5.0, "m") == []


def _bilinear(mag, name, i_d, i_q):
    """The plant's bilinear lookup written out on the 2-D table (the
    reference the design's interp_tables must equal bit for bit)."""
    e_d, e_q = np.asarray(mag["i_d"]), np.asarray(mag["i_q"])
    x = np.clip((np.asarray(i_d, float) - e_d[0]) / (e_d[1] - e_d[0]), 0.0, e_d.size - 1.0)
    y = np.clip((np.asarray(i_q, float) - e_q[0]) / (e_q[1] - e_q[0]), 0.0, e_q.size - 1.0)
    k, n = np.minimum(x.astype(int), e_d.size - 2), np.minimum(y.astype(int), e_q.size - 2)
    a, b = x - k, y - n
    t = np.asarray(mag[name])
    return (1 - a) * (1 - b) * t[k, n] + a * (1 - b) * t[k + 1, n] + (1 - a) * b * t[k, n + 1] + a * b * t[k + 1, n + 1]


@pytest.mark.parametrize("k", [0, 6])
def test_the_design_reads_a_map_and_searches_mtpa_as_the_whole_grid_would_bit_for_bit(k):
    """interp_tables (weights made once, corners from the flat table) and
    mtpa_locus (a few magnitudes a pass) against the formula and the whole
    grid's search: the same bits, on a non-square table (a saturating zoo
    machine's, cut) and at points beyond its edges, where it holds."""
    from fullspeed.design.envelope import flux_table
    from fullspeed.design.magnetics import MTPA_ANGLES, MTPA_N, mtpa_locus
    from fullspeed.model.fluxmap import interp_tables

    sc = load_scenario("beyond-zoo", {"machine": {"zoo": k}}, False)
    m, i_max = sc.machine, sc.data["controller"]["i_max"]
    full = flux_table(m, i_max)
    mag = {"i_d": full["i_d"], "i_q": full["i_q"][:-5], "psi_d": full["psi_d"][:, :-5], "psi_q": full["psi_q"][:, :-5]}
    rng = np.random.default_rng(k)
    i_d, i_q = rng.uniform(-1.3 * i_max, 0.3 * i_max, (30, 7)), rng.uniform(-0.3 * i_max, 1.3 * i_max, (30, 7))
    got = interp_tables(mag, ("psi_d", "psi_q"), i_d, i_q)
    for name, g in zip(("psi_d", "psi_q"), got):
        assert g.tobytes() == _bilinear(mag, name, i_d, i_q).tobytes()
    assert float(interp_tables(mag, ("psi_q",), -0.2 * i_max, 0.4 * i_max)[0]) == float(_bilinear(mag, "psi_q", -0.2 * i_max, 0.4 * i_max))
    I = i_max * np.arange(MTPA_N) / (MTPA_N - 1)
    g = np.linspace(0.5 * np.pi, np.pi, MTPA_ANGLES)
    d, q = np.outer(I, np.cos(g)), np.outer(I, np.sin(g))
    T = 0.5 * m.phases * m.pole_pairs * (_bilinear(full, "psi_d", d, q) * q - _bilinear(full, "psi_q", d, q) * d)
    best = np.argmax(T, axis=1)
    r = np.arange(MTPA_N)
    ref = [T[r, best], d[r, best], q[r, best]]
    for x in ref:
        x[0] = 0.0
    for x, y in zip(mtpa_locus(full, i_max, m.phases, m.pole_pairs), ref):
        assert x.tobytes() == y.tobytes()


@pytest.mark.parametrize("scale, hint", [(3.0, False), (1000.0, True), (1e-3, True)])
def test_a_map_and_a_file_that_describe_two_machines_are_refused(tmp_path, scale, hint):
    """The new-user trial's psi_f in mWb written as Wb (1000 x off) was warned,
    then the run failed on a cause the warning did not name. Beyond a factor
    2 [electrical] and the map are two machines: refused naming the field,
    its value, the map's and the factor (with the unit's hint near 1000)."""
    write_csv(tmp_path / "map.csv", scale=scale)
    (tmp_path / "m.toml").write_text(MACHINE.format(i_max=40.0).replace("i_max = 40.0", "i_max = 25.0"))
    with pytest.raises(ConfigError) as e:
        load_machine(tmp_path / "m.toml")
    msg = str(e.value)
    assert "machine.electrical.psi_f = 0.0105" in msg and f"{scale:.3g} x this" in msg and "within a factor 2" in msg
    assert ("is a unit" in msg) == hint


@pytest.mark.parametrize("reach, below_rated", [(20.0, True), (35.0, False)])
def test_a_map_short_of_the_rated_current_says_the_rated_torque_is_out_of_reach(tmp_path, reach, below_rated):
    """The new-user trial's map trimmed to +-10 A on a 12.4 A machine: the
    limit was held to the map and nothing said the rated torque was out of
    reach. A map short of 1.5 x rated says it is held; short of the rated
    current itself, also that the rated torque cannot be made."""
    grid = np.array([-reach, -reach / 2, 0.0, reach / 2, reach])
    write_csv(tmp_path / "map.csv", i_d=grid, i_q=np.array([0.0, reach / 2, reach]))
    toml = MACHINE.format(i_max=40.0).replace("i_max = 40.0\ni_trip = 52.0\nadc_range = 60.0\n", "")
    (tmp_path / "m.toml").write_text(toml)
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        load_machine(tmp_path / "m.toml")
    held = [str(x.message) for x in w if "the current limit is held to" in str(x.message)]
    assert len(held) == 1
    assert ("cannot make its rated torque (3 N m)" in held[0]) == below_rated


@pytest.mark.parametrize("flip, hint", [("i_d", "its i_d axis (or psi_d) has the other sign"),
                                        ("i_q", "its i_q axis (or psi_q) has the other sign"), (None, None)])
def test_a_current_axis_of_the_other_sign_is_named(tmp_path, flip, hint):
    """The new-user trial negated the map's i_d axis: refused as not monotonic
    at one cell, with no word of the sign. A flux falling with its current
    over the whole map is an axis of the other sign, and the refusal says so;
    one bad point says only where it is."""
    i_d = -I_D[::-1] if flip == "i_d" else I_D   # the same points, the axis' sign turned
    i_q = I_Q
    lines = ["# FEA export", "i_d [A],i_q [A],psi_d [Wb],psi_q [Wb]"]
    for a in i_d:
        for b in (np.concatenate([-I_Q[:0:-1], I_Q]) if flip == "i_q" else i_q):
            pd, pq = psi(-a if flip == "i_d" else a, -b if flip == "i_q" else b)
            if flip is None and a == I_D[2] and b == I_Q[1]:
                pd = psi(I_D[0], b)[0] - 5e-3   # one bad point, below the whole column
            lines.append(f"{a},{b},{pd:.9g},{pq:.9g}")
    (tmp_path / "map.csv").write_text("\n".join(lines) + "\n")
    (tmp_path / "m.toml").write_text(MACHINE.format(i_max=40.0).replace("i_max = 40.0", "i_max = 25.0"))
    with pytest.raises(ConfigError) as e:
        load_machine(tmp_path / "m.toml")
    msg = str(e.value)
    assert "a monotonic map" in msg
    assert (hint in msg) if hint else ("other sign" not in msg)
