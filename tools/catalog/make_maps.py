"""Write the flux maps of the published-machine catalog (src/fullspeed/machines/*.csv)
from their published sources. Run from the repository root:

    python tools/catalog/make_maps.py --motulator-sdist DIR/motulator-0.5.0.tar.gz

(`pip download motulator==0.5.0 --no-deps --no-binary :all: -d DIR` gives the sdist;
without it the THOR map is left as it is and the others are written.)

Each map is in the PMSM convention of fullspeed.model.fluxmap: the magnet on +d, so
psi_d(0, 0) = psi_f > 0 and psi_q(i_d, 0) = 0; peak phase currents (A) and flux
linkages (Wb), amplitude-invariant dq. The maps are given for i_q >= 0; the loader
completes them by the machine's symmetry, psi_q(i_d, -i_q) = -psi_q(i_d, i_q).

- prius2004-mg2.csv: BUILT from the published L_d and L_q against current (two points
  per axis) as secant (apparent) inductances, psi = psi_f + L(i) i: see prius().
- hefei-h27.csv: BUILT from the drive's own published L_q(|i_q|) table, read as the
  drive reads it (secant, psi_q = L_q(|i_q|) i_q): see h27().
- baldor-ecs101m0h7ef4.csv: MEASURED on a bench (motulator's data, MIT), written as is.
- syre-thor.csv: FEA (SyR-e, Apache-2.0, as shipped in motulator 0.5.0, MIT),
  subsampled and turned to the PMSM convention.
"""
from __future__ import annotations

import argparse
import hashlib
import io
import tarfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "src" / "fullspeed" / "machines"
DATA = Path(__file__).resolve().parent / "data"


def sha256(b: bytes) -> str:
    return hashlib.sha256(b).hexdigest()


def write_map(out: Path, name: str, comments: list[str], i_d, i_q, psi_d, psi_q, torque=None) -> Path:
    """One row per (i_d[k], i_q[l]); tables [k][l]. Written atomically."""
    head = ["i_d [A]", "i_q [A]", "psi_d [Wb]", "psi_q [Wb]"] + (["T [N m]"] if torque is not None else [])
    lines = [f"# {c}" for c in comments]
    lines += [f"# written by tools/catalog/make_maps.py; edit that script, not this file", ",".join(head)]
    for k, a in enumerate(i_d):
        for n, b in enumerate(i_q):
            row = [f"{a:.6g}", f"{b:.6g}", f"{psi_d[k][n]:.8g}", f"{psi_q[k][n]:.8g}"]
            if torque is not None:
                row.append(f"{torque[k][n]:.8g}")
            lines.append(",".join(row))
    path = out / f"{name}.csv"
    tmp = path.with_suffix(".csv.tmp")
    tmp.write_text("\n".join(lines) + "\n")
    tmp.replace(path)
    return path


# ---------------------------------------------------------------------------
# 2004 Toyota Prius MG2
# Published (Kuptsov et al., Machines 7(4):75, 2019, FEM d-q parameterisation
# validated against ORNL, as transcribed with its figure references in
# github.com/jonelay/phase-sweep motors/prius_2004.toml @ a90786d): L_d = 2.26 mH and
# L_q = 6.15 mH at moderate load (Eq. 13), falling to about 1.8 mH and 3 mH on the
# 200 A curve of Fig. 5; psi_f = 0.1607 Wb, the fundamental calibrated to ORNL's
# measured back-EMF (ORNL/TM-2004/185).
PRIUS_PSI_F = 0.1607
PRIUS_L = {"d": (2.26e-3, 1.80e-3), "q": (6.15e-3, 3.00e-3)}   # (low current, at PRIUS_I_SAT)
PRIUS_I_SAT = 200.0


def prius_secant(axis: str, i):
    """The secant inductance L(i) = L_0 / (1 + |i| / a) through the two published
    points, L_0 at zero current and L_1 at PRIUS_I_SAT (a = I_SAT / (L_0/L_1 - 1)).
    Read as secant: psi = L(i) i then saturates towards L_0 a, and the incremental
    inductance dpsi/di = L_0 / (1 + |i|/a)^2 stays positive (a monotonic map)."""
    L0, L1 = PRIUS_L[axis]
    a = PRIUS_I_SAT / (L0 / L1 - 1.0)
    return L0 / (1.0 + np.abs(i) / a)


def prius(out: Path = OUT):
    i_d = np.arange(-300.0, 300.0 + 1e-9, 5.0)      # covers -i_max..i_max/2 for i_max up to 300 A, and the +i_d side as wide
    i_q = np.arange(0.0, 300.0 + 1e-9, 5.0)
    D, Q = np.meshgrid(i_d, i_q, indexing="ij")
    psi_d = PRIUS_PSI_F + prius_secant("d", D) * D   # own-axis current: no cross-saturation published
    psi_q = prius_secant("q", Q) * Q
    (Ld0, Ld1), (Lq0, Lq1) = PRIUS_L["d"], PRIUS_L["q"]
    return write_map(out, "prius2004-mg2", [
        "2004 Toyota Prius MG2: flux map BUILT from published inductances, not measured.",
        f"psi_d = psi_f + L_d(|i_d|) i_d, psi_q = L_q(|i_q|) i_q, secant L(i) = L_0/(1 + |i|/a) through "
        f"L_d {Ld0 * 1e3:g} -> {Ld1 * 1e3:g} mH and L_q {Lq0 * 1e3:g} -> {Lq1 * 1e3:g} mH at {PRIUS_I_SAT:g} A, psi_f {PRIUS_PSI_F:g} Wb",
        "sources: Kuptsov et al., Machines 7(4):75, 2019 (Eq. 13, Fig. 5), via github.com/jonelay/phase-sweep "
        "motors/prius_2004.toml @ a90786d; ORNL/TM-2004/185 (back-EMF)",
        "symmetric in i_d: the published data give no d-axis saturation asymmetry (none is added)",
    ], i_d, i_q, psi_d, psi_q)


# ---------------------------------------------------------------------------
# Hefei H27 washer IPMSM: the appliance drive's own parameter sheet,
# github.com/ehcouto/WindyStrip_DTC_Orca source/ProjectSpecific/Mci/Mcl/Mcl_prm_all_motors.h
# (@ ae2eede): psi_f 0.0845 Wb, L_d 21.17 mH at every current, L_q at 0..6 A; its
# observer (source/XCategory/Hbl/Mci/Mcl/MacroBlocks/MclObserver.c) looks L_d up at
# |i_d| and L_q at |i_q| and forms psi_d = psi_f + L_d i_d, psi_q = L_q i_q (secant),
# with the cross inductance 0 as published; the table's last entry repeats 6 A, so
# the drive holds L_q beyond 6 A.
H27_PSI_F = 0.0845
H27_L_D = 21.17e-3
H27_I_TAB = np.array([0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
H27_L_Q_TAB = np.array([27.44, 27.77, 27.42, 26.46, 24.26, 23.29, 22.41]) * 1e-3


def h27(out: Path = OUT):
    i_d = np.arange(-8.0, 8.0 + 1e-9, 0.25)
    i_q = np.arange(0.0, 8.0 + 1e-9, 0.25)
    D, Q = np.meshgrid(i_d, i_q, indexing="ij")
    psi_d = H27_PSI_F + H27_L_D * D
    psi_q = np.interp(np.abs(Q), H27_I_TAB, H27_L_Q_TAB) * Q   # linear between entries, held beyond 6 A, as the drive's LUT
    return write_map(out, "hefei-h27", [
        "Hefei H27 washer IPMSM: flux map BUILT from the drive's published inductance table, not measured.",
        "psi_d = psi_f + L_d i_d (L_d constant, as published), psi_q = L_q(|i_q|) i_q with L_q linear between the",
        "published entries at 0..6 A and held beyond (as the drive's lookup); cross inductance 0 (published)",
        "source: github.com/ehcouto/WindyStrip_DTC_Orca source/ProjectSpecific/Mci/Mcl/Mcl_prm_all_motors.h @ ae2eede",
    ], i_d, i_q, psi_d, psi_q)


# ---------------------------------------------------------------------------
# Baldor ECS101M0H7EF4 5.6 kW PM-SyRM: the flux map measured at 400 rpm
# (motulator, examples/drive/flux_vector/baldor_400rpm_map.npz @ 808d1df, MIT).
BALDOR_SHA256 = "de4df6ddf0dad5a93db0c9baff1f4b2d00e85c94ef3e8ba3737059d0cfec5845"


def baldor(out: Path = OUT):
    raw = (DATA / "baldor_400rpm_map.npz").read_bytes()
    if sha256(raw) != BALDOR_SHA256:
        raise SystemExit("tools/catalog/data/baldor_400rpm_map.npz is not the published file (sha256 differs)")
    d = np.load(io.BytesIO(raw))
    i, psi = d["i_s_dq"], d["psi_s_dq"]          # [k][l] at (i_d[k], i_q[l]), i_d along axis 0
    i_d, i_q = i.real[:, 0], i.imag[0, :]
    assert np.allclose(i.real, i_d[:, None]) and np.allclose(i.imag, i_q[None, :])
    # its orientation is the PMSM convention already: the magnet along +d
    # (psi_d(0, 0) = +0.444 Wb, psi_q(i_d, 0) = 0) and the large inductance along q
    keep = i_q >= -1e-9
    return write_map(out, "baldor-ecs101m0h7ef4", [
        "Baldor ECS101M0H7EF4 5.6 kW PM-SyRM: flux map MEASURED (constant-speed test at 400 rpm), as published.",
        "source: motulator (github.com/Aalto-Electric-Drives/motulator) examples/drive/flux_vector/baldor_400rpm_map.npz "
        f"@ 808d1df (sha256 {BALDOR_SHA256[:12]}); MIT licence: LICENSE-motulator.txt beside this file",
        "orientation: magnet on +d (psi_d(0,0) = 0.444 Wb), the large (reluctance) inductance on q; only i_q >= 0 "
        "written (the published map is symmetric in i_q)",
    ], i_d, i_q[keep], psi.real[:, keep], psi.imag[:, keep])


# ---------------------------------------------------------------------------
# SyR-e THOR 5 kW PM-SyRM, FEA: motorModel.FluxMap_dq of THOR.mat in the motulator
# 0.5.0 sdist (examples/drive/obs_vhz/THOR.mat), 256 x 256 points, SyR-e's axes
# (magnet on -q): turned to the PMSM convention, i_d = -Iq, i_q = Id, psi_d = -Fq,
# psi_q = Fd (fullspeed.model.fluxmap does the same for a .mat), every 5th point.
THOR_MEMBER = "motulator-0.5.0/examples/drive/obs_vhz/THOR.mat"
THOR_SHA256 = "1a32b3f8f69d2fb35f9c69071eb169059d67b1500ca98fee76b82ac4c332043e"
THOR_STEP = 5        # 256 points (255 intervals) -> 52: 2.6 A in i_d, 1.3 A in i_q, the FEA points themselves


def thor(sdist: Path, out: Path = OUT):
    from scipy.io import loadmat
    with tarfile.open(sdist) as tf:
        raw = tf.extractfile(THOR_MEMBER).read()
    if sha256(raw) != THOR_SHA256:
        raise SystemExit(f"{THOR_MEMBER} in {sdist} is not the published file (sha256 differs)")
    fm = loadmat(io.BytesIO(raw))["motorModel"][0, 0]["FluxMap_dq"][0, 0]
    Id, Iq, Fd, Fq, T = (np.asarray(fm[k], float) for k in ("Id", "Iq", "Fd", "Fq", "T"))
    # Id varies along axis 1, Iq along axis 0 (meshgrid 'xy'); PMSM i_d = -Iq rising: Iq falling
    assert np.allclose(Id, Id[0:1, :]) and np.allclose(Iq, Iq[:, 0:1])
    rows = np.arange(0, Iq.shape[0], THOR_STEP)[::-1]
    cols = np.arange(0, Id.shape[1], THOR_STEP)
    sub = lambda a: a[np.ix_(rows, cols)]   # noqa: E731   [k][l] at (i_d[k], i_q[l])
    i_d, i_q = -Iq[rows, 0], Id[0, cols]
    return write_map(out, "syre-thor", [
        "SyR-e THOR 5 kW PM-SyRM: flux map from FEA (SyR-e), every 5th point of its 256 x 256 FluxMap_dq.",
        "turned to the PMSM convention: i_d = -Iq, i_q = Id, psi_d = -Fq, psi_q = Fd (SyR-e puts the magnet on -q); T as computed by SyR-e",
        f"source: motulator 0.5.0 sdist (PyPI) {THOR_MEMBER} (sha256 {THOR_SHA256[:12]}), from SyR-e motorExamples/THOR.mat",
        "licences: SyR-e, Apache-2.0 (LICENSE-syre.txt); motulator 0.5.0, MIT (LICENSE-motulator-0.5.0.txt); changed: subsampled, axes turned",
    ], i_d, i_q, -sub(Fq), sub(Fd), sub(T))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--motulator-sdist", type=Path, help="motulator-0.5.0.tar.gz (for the THOR map)")
    ap.add_argument("--out", type=Path, default=OUT, help="where to write the maps (default: the catalog)")
    a = ap.parse_args(argv)
    written = [prius(a.out), h27(a.out), baldor(a.out)]
    if a.motulator_sdist:
        written.append(thor(a.motulator_sdist, a.out))
    else:
        print("THOR map left as it is: give --motulator-sdist (pip download motulator==0.5.0 --no-deps --no-binary :all:)")
    for p in written:
        print(f"wrote {p} ({p.stat().st_size} B)")


if __name__ == "__main__":
    main()
