"""A flux-map file whose magnet does not lie on +d is refused naming where
it lies and the turn that mends it (a swapped Baldor map ended in
'controller.T_max is required: makes no torque by MTPA')."""
import numpy as np
import pytest

from fullspeed.model.errors import ConfigError
from fullspeed.model.fluxmap import load_map

I_D, I_Q = np.linspace(-20.0, 20.0, 11), np.linspace(-20.0, 20.0, 11)
PSI_F, L_D, L_Q = 0.4, 0.02, 0.06


def write(path, d_of, q_of):
    """A linear machine's map written with its axes given by d_of, q_of:
    functions of (i_d, i_q, psi_d, psi_q) -> (the file's i, the file's psi)."""
    rows = ["i_d [A],i_q [A],psi_d [Wb],psi_q [Wb]"]
    for a in I_D:
        for b in I_Q:
            pd, pq = PSI_F + L_D * a, L_Q * b
            (fa, fpd), (fb, fpq) = d_of(a, b, pd, pq), q_of(a, b, pd, pq)
            rows.append(f"{fa:g},{fb:g},{fpd:g},{fpq:g}")
    path.write_text("\n".join(rows) + "\n")
    return path


def test_the_magnet_on_d_loads(tmp_path):
    f = write(tmp_path / "d.csv", lambda a, b, pd, pq: (a, pd), lambda a, b, pd, pq: (b, pq))
    assert load_map(f, "magnetic.file")["model"] == "fluxmap"


@pytest.mark.parametrize("where, d_of, q_of", [
    ("+q", lambda a, b, pd, pq: (-b, -pq), lambda a, b, pd, pq: (a, pd)),    # the frame turned by -90 el.deg
    ("-q", lambda a, b, pd, pq: (b, pq), lambda a, b, pd, pq: (-a, -pd)),    # by +90: SyR-e's convention
    ("-d", lambda a, b, pd, pq: (-a, -pd), lambda a, b, pd, pq: (-b, -pq)),  # by 180
])
def test_a_magnet_elsewhere_is_refused_with_its_turn(tmp_path, where, d_of, q_of):
    f = write(tmp_path / "m.csv", d_of, q_of)
    with pytest.raises(ConfigError) as e:
        load_map(f, "magnetic.file")
    msg = str(e.value)
    assert f"its flux lies on {where}" in msg and "the magnet must lie on +d" in msg and "\n" not in msg, msg
    # the turn it names, done, gives a map that loads with the magnet's flux on +d
    turned = {"+q": lambda r: (r[1], -r[0], r[3], -r[2]), "-q": lambda r: (-r[1], r[0], -r[3], r[2]),
              "-d": lambda r: (-r[0], -r[1], -r[2], -r[3])}[where]
    lines = f.read_text().splitlines()
    body = [turned([float(x) for x in line.split(",")]) for line in lines[1:]]
    g = tmp_path / "turned.csv"
    g.write_text("\n".join([lines[0], *(",".join(f"{x:g}" for x in r) for r in body)]) + "\n")
    mag = load_map(g, "magnetic.file")
    k = np.argmin(np.abs(np.asarray(mag["i_d"]))), np.argmin(np.abs(np.asarray(mag["i_q"])))
    assert np.asarray(mag["psi_d"])[k] == pytest.approx(PSI_F) and abs(np.asarray(mag["psi_q"])[k]) < 1e-9
