"""The design's searches kept per machine (design.memo): a kept result is the
one the search makes, a changed machine gets its own, and what a caller
does to its copy does not reach the next caller."""
from __future__ import annotations

import dataclasses

import numpy as np

from fullspeed.design.envelope import Limits, envelope, limits
from fullspeed.design.machine import load_machine
from fullspeed.design.memo import machine_key
from fullspeed.design.xcomp import designed_table
from fullspeed.model.fluxmap import interp, interp_tables, load_map


def _fresh(name: str):
    return load_machine(name)


def test_a_machine_read_twice_has_one_key_and_a_changed_one_another():
    a, b = _fresh("yang2022"), _fresh("yang2022")
    assert a is not b and machine_key(a) == machine_key(b)
    assert machine_key(dataclasses.replace(a, R_s=a.R_s * (1.0 + 1e-15))) != machine_key(a)
    first = next(k for k, v in a.magnetic.items() if isinstance(v, float))
    d = dataclasses.replace(a, magnetic={**a.magnetic, first: float(np.nextafter(a.magnetic[first], np.inf))})
    assert machine_key(d) != machine_key(a)


def test_a_kept_envelope_is_the_searched_one_and_its_copy_is_the_callers():
    m = _fresh("prius2004-mg2")
    u_dc, i_max = m.bench["u_dc"], m.bench["i_max"]
    first = envelope(m, u_dc, i_max)
    first.T[:] = -1.0   # the caller's copy: the next caller must not see it
    again = envelope(_fresh("prius2004-mg2"), u_dc, i_max)
    lim = Limits(_fresh("prius2004-mg2"), u_dc, i_max)   # the search made anew, not kept
    T, _, _ = lim.best(again.w_m[:5] * lim.p)
    assert np.all(again.T[:5] == T)
    assert again.T[0] > 0.0


def test_kept_limits_answer_as_new_ones_and_differ_with_the_limit():
    m = _fresh("yang2022")
    u_dc, i_max = m.bench["u_dc"], m.bench["i_max"]
    kept, new = limits(m, u_dc, i_max), Limits(_fresh("yang2022"), u_dc, i_max)
    assert limits(_fresh("yang2022"), u_dc, i_max) is kept
    w = np.array([0.5, 1.0, 2.0]) * kept.p * m.w_m_rated
    assert all(np.array_equal(x, y) for x, y in zip(kept.best(w), new.best(w)))
    assert limits(m, u_dc, 0.5 * i_max) is not kept


def test_a_kept_table_is_the_designed_one_and_its_copy_is_the_callers():
    m = _fresh("yang2022")
    table, note = designed_table(m, m.bench["i_max"])
    assert table is not None
    table["delta_deg"][0] = 1e9
    again, note2 = designed_table(_fresh("yang2022"), m.bench["i_max"])
    assert again["delta_deg"][0] != 1e9 and note2.value == note.value


def _bilinear(mag: dict, name: str, i_d, i_q):
    """The map's bilinear reading as interp had it before the tables were read together."""
    e_d, e_q, t = np.asarray(mag["i_d"]), np.asarray(mag["i_q"]), np.asarray(mag[name])
    x = np.clip((np.asarray(i_d, float) - e_d[0]) / (e_d[1] - e_d[0]), 0.0, e_d.size - 1.0)
    y = np.clip((np.asarray(i_q, float) - e_q[0]) / (e_q[1] - e_q[0]), 0.0, e_q.size - 1.0)
    k, n = np.minimum(x.astype(int), e_d.size - 2), np.minimum(y.astype(int), e_q.size - 2)
    a, b = x - k, y - n
    return ((1 - a) * (1 - b) * t[k, n] + a * (1 - b) * t[k + 1, n]
            + (1 - a) * b * t[k, n + 1] + a * b * t[k + 1, n + 1])


def test_the_tables_read_together_are_each_the_bilinear_reading_to_the_bit():
    mag = _fresh("prius2004-mg2").magnetic
    rng = np.random.default_rng(3)
    # inside, on the grid's own points and beyond its edges (held there)
    i_d = np.r_[rng.uniform(mag["i_d"][0], mag["i_d"][-1], 500), mag["i_d"][:3], mag["i_d"][0] - 1.0, mag["i_d"][-1] + 1.0]
    i_q = np.r_[rng.uniform(mag["i_q"][0], mag["i_q"][-1], 500), mag["i_q"][-3:], mag["i_q"][-1] + 1.0, mag["i_q"][0] - 1.0]
    psi_d, psi_q = interp_tables(mag, ("psi_d", "psi_q"), i_d, i_q)
    assert np.array_equal(psi_d, _bilinear(mag, "psi_d", i_d, i_q))
    assert np.array_equal(psi_q, _bilinear(mag, "psi_q", i_d, i_q))
    assert interp(mag, "psi_q", 1.0, 2.0) == _bilinear(mag, "psi_q", 1.0, 2.0)


def test_a_map_file_read_again_is_a_copy_and_a_rewritten_file_is_read_anew(tmp_path):
    src = load_machine("prius2004-mg2").magnetic["file"]
    f = tmp_path / "map.csv"
    f.write_text(open(src).read())
    first = load_map(f, "magnetic.file")
    first["psi_d"][0][0] = 1e9
    again = load_map(f, "magnetic.file")
    assert again["psi_d"][0][0] != 1e9
    # the same file with its first data row's fluxes doubled: another map, read as such
    lines = f.read_text().splitlines()
    k = next(i for i, line in enumerate(lines) if line[:1] == "-" or line[:1].isdigit())
    cols = lines[k].split(",")
    lines[k] = ",".join(cols[:2] + [repr(2 * float(c)) for c in cols[2:]])
    f.write_text("\n".join(lines) + "\n")
    rewritten = load_map(f, "magnetic.file")
    changed = [(a, b) for ra, rb in zip(again["psi_d"], rewritten["psi_d"]) for a, b in zip(ra, rb) if a != b]
    assert changed and all(b == 2 * a for a, b in changed)
