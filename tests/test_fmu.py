"""The FMUs of the drive and of the closed loop (workflows/fmu.py, csrc/fmu),
checked by an independent FMI tool, FMPy: its validation, its simulation of
the system FMU against fullspeed's run, and the drive FMU stepped through its
API on fullspeed's plant against the host's drive, FMI 3.0 and 2.0. The
four FMUs are built once per session (beyond-full-range's first 0.4 s:
polarity detection and injection under the load), and the MATLAB export."""
from __future__ import annotations

import zipfile

import numpy as np
import pytest

fmpy = pytest.importorskip("fmpy")

from fmpy import read_model_description, simulate_fmu  # noqa: E402

from fullspeed.cli import main  # noqa: E402
from fullspeed.design.scenario import load_scenario  # noqa: E402
from fullspeed.model.errors import ConfigError  # noqa: E402
from fullspeed.sim import UNITS, build_config, simulate  # noqa: E402
from fullspeed.workflows.export import render  # noqa: E402
from fullspeed.workflows.fmu import UNITS as FMU_UNITS, control_period, export_fmu, host_platform  # noqa: E402
from fullspeed.workflows.fmu_check import drive_vs_host, system_vs_run, validate  # noqa: E402

T = 0.4


def _scenario():
    return load_scenario("beyond-full-range", {"duration": T, "metrics": {"steady": [0.0, T]}})


@pytest.fixture(scope="session")
def fmus(tmp_path_factory):
    """{(kind, fmi): path} of the four FMUs."""
    sc = _scenario()
    out = {}
    for fmi in (3, 2):
        drive, system = export_fmu(sc, tmp_path_factory.mktemp(f"fmi{fmi}"), ("drive", "system"), fmi)
        out[("drive", fmi)], out[("system", fmi)] = drive, system
    return out


@pytest.mark.parametrize("fmi", [3, 2])
@pytest.mark.parametrize("kind", ["drive", "system"])
def test_fmpy_validates_the_model_description(fmus, kind, fmi):
    assert validate(fmus[(kind, fmi)]) == []


@pytest.mark.parametrize("fmi", [3, 2])
def test_the_model_description_names_units_the_step_and_the_binary(fmus, fmi):
    sc = _scenario()
    cfg, _keep = build_config(sc)
    for kind in ("drive", "system"):
        md = read_model_description(str(fmus[(kind, fmi)]))
        assert md.fmiVersion == f"{fmi}.0"
        assert md.defaultExperiment.stepSize == repr(control_period(cfg)) or \
            float(md.defaultExperiment.stepSize) == control_period(cfg)
        real = [v for v in md.modelVariables if v.type in ("Real", "Float64")]
        assert real and all(v.unit in FMU_UNITS for v in real), [v.name for v in real if v.unit not in FMU_UNITS]
        names = {v.name: v for v in md.modelVariables}
        assert md.coSimulation.canHandleVariableCommunicationStepSize in (False, "false", None)
        folder, suffix = host_platform(fmi)
        with zipfile.ZipFile(fmus[(kind, fmi)]) as zf:
            files = set(zf.namelist())
            bd = zf.read("sources/buildDescription.xml").decode()
        assert f"binaries/{folder}/{md.coSimulation.modelIdentifier}{suffix}" in files
        sources = {f[len("sources/"):] for f in files if f.startswith("sources/") and f.endswith(".c")}
        assert sources and all(f'name="{s}"' in bd for s in sources)
        if kind == "drive":
            for v in ("i_a", "i_b", "i_c", "u_dc", "w_m_ref", "sensorless"):
                assert names[v].causality == "input", v
            for v in ("duty_a", "duty_b", "duty_c", "theta_e", "w_e", "stage", "fault"):
                assert names[v].causality == "output", v
            assert names["R_s"].causality == "parameter" and names["R_s"].variability == "fixed"
            assert names["u_dc"].unit == "V" and names["w_m_ref"].unit == "rad/s"
            assert "i_q_ref" not in names   # a speed-mode scenario: no current references
        else:
            assert {names["w_m_ref"].causality, names["T_load"].causality} == {"input"}
            for v in ("w_m", "T_e", "i_a", "i_dc", "P_dc", "theta_err", "stage", "stop"):
                assert names[v].causality == "output", v
            assert names["P_dc"].unit == "W" and "w_load" not in names


def test_the_drive_fmu_carries_the_firmware_export(fmus):
    header, source = render(_scenario(), "fs_config")
    with zipfile.ZipFile(fmus[("drive", 3)]) as zf:
        assert zf.read("sources/control/fs_config.c").decode() == source
        assert zf.read("sources/control/fs_config.h").decode() == header


@pytest.mark.parametrize("fmi", [3, 2])
def test_fmpy_simulates_the_system_fmu_as_fullspeed_runs_it(fmus, fmi):
    r = system_vs_run(fmus[("system", fmi)], _scenario())
    assert r["steps"] == round(T * 1e4) - 1 and r["run_stop"] == "done" and r["fmu_stop"] == 0
    assert r["bitwise"], r
    assert {2, 4} <= set(r["stages"])   # polarity detection, then injection


@pytest.mark.parametrize("fmi", [3, 2])
def test_the_drive_fmu_on_fullspeeds_plant_is_the_host_drive_bit_for_bit(fmus, fmi):
    r = drive_vs_host(fmus[("drive", fmi)], _scenario())
    assert r["steps"] == round(T * 1e4) and r["stop"] == "done"
    assert r["bitwise"], r
    assert {2, 4} <= set(r["stages"])


def test_a_step_other_than_the_control_period_or_a_parameter_after_init_is_refused(fmus):
    from fmpy import extract, instantiate_fmu
    from fmpy.fmi1 import FMICallException

    path = fmus[("drive", 3)]
    md = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = instantiate_fmu(extract(str(path)), md, fmi_type="CoSimulation")
    fmu.enterInitializationMode(startTime=0.0)
    fmu.exitInitializationMode()
    Ts = float(md.defaultExperiment.stepSize)
    with pytest.raises(FMICallException):
        fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=2 * Ts)
    with pytest.raises(FMICallException):
        fmu.setFloat64([vr["R_s"]], [0.1])
    fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=Ts)   # the right step still goes
    assert fmu.getInt32([vr["stage"]])[0] == 2                          # polarity detection first
    fmu.freeInstance()


def test_a_parameter_set_before_init_reaches_the_drive(fmus):
    """bw_current set before initialization: fs_drive_init designs the
    current loop from it, so the duties leave the exported drive's."""
    path = fmus[("drive", 3)]
    sc = _scenario()
    base = simulate_fmu(str(path), stop_time=0.01, output_interval=1e-4, output=["duty_a"])
    other = simulate_fmu(str(path), stop_time=0.01, output_interval=1e-4, output=["duty_a"],
                         start_values={"bw_current": 0.5 * float(build_config(sc)[0].drive.bw_current)})
    assert len(base) == len(other) > 50
    assert not np.array_equal(base["duty_a"], other["duty_a"])


def test_refusals_name_the_field(tmp_path):
    with pytest.raises(ConfigError, match="--fmi"):
        export_fmu("beyond-full-range", tmp_path, ("drive",), fmi=1)
    with pytest.raises(ConfigError, match="converter.kind"):
        export_fmu("zou2021-region-b", tmp_path, ("drive",))
    assert main(["export", "beyond-full-range", "--fmu", "--name", "x", "--out", str(tmp_path)]) == 2
    assert not list(tmp_path.iterdir())   # nothing written


def test_cli_writes_both_fmus(tmp_path, capsys):
    assert main(["export", "yang2022-smo-steady-400rpm", "--fmu", "--fmu-system", "--fmi", "2",
                 "--out", str(tmp_path)]) == 0
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ["yang2022-smo-steady-400rpm-drive.fmu", "yang2022-smo-steady-400rpm-system.fmu"]
    assert "FMI 2.0" in capsys.readouterr().out
    for p in tmp_path.iterdir():
        assert validate(p) == []


def test_traces_as_a_mat_file_load_with_their_units(tmp_path):
    sio = pytest.importorskip("scipy.io")
    res = simulate("yang2022-smo-steady-400rpm", overrides={"duration": 0.25, "metrics": {"steady": [0.0, 0.25]}})
    res.to_mat(tmp_path / "r.mat")
    m = sio.loadmat(tmp_path / "r.mat", squeeze_me=True, struct_as_record=False)
    for name in ("t", "w_m", "i_q", "stage"):
        assert np.array_equal(getattr(m["traces"], name), res[name]), name
        assert getattr(m["units"], name) == UNITS[name]
    assert m["scenario"] == "yang2022-smo-steady-400rpm" and m["stop_reason"] == "done"
    assert m["metrics"].i_phase_max == res.metrics["i_phase_max"] and m["metrics"].T_e_pp == res.metrics["T_e_pp"]
    assert m["metrics"].true_loss_at.size == 0   # None: MATLAB's empty
    assert list(m["stage_names"])[:2] == ["open", "sensor"]


def test_the_drive_fmu_builds_from_its_sources_and_build_description(fmus, tmp_path):
    """What another platform does: the C files sources/buildDescription.xml
    lists, compiled with its options by plain cc, in place of the binary;
    FMPy's run of that build gives the shipped binary's duties."""
    import re
    import shutil
    import subprocess
    from concurrent.futures import ThreadPoolExecutor

    from fmpy import extract

    path = fmus[("drive", 3)]
    root = tmp_path / "fmu"
    extract(str(path), str(root))
    bd = (root / "sources" / "buildDescription.xml").read_text()
    files = re.findall(r'<SourceFile name="([^"]+)"', bd)
    options = re.search(r'compilerOptions="([^"]+)"', bd).group(1).split()
    assert "fmu/fs_fmi3.c" in files and "control/fs_config.c" in files and "-ffp-contract=off" in options
    md = read_model_description(str(path))
    (binary,) = (root / "binaries").rglob(f"{md.coSimulation.modelIdentifier}.*")
    binary.unlink()
    cc = shutil.which("cc") or "cc"

    def compile_one(name):
        obj = tmp_path / (name.replace("/", "_") + ".o")
        subprocess.run([cc, *options, "-fPIC", "-c", str(root / "sources" / name), "-o", str(obj)], check=True)
        return str(obj)

    with ThreadPoolExecutor() as pool:
        objs = list(pool.map(compile_one, files))
    subprocess.run([cc, "-shared", "-o", str(binary), *objs, "-lm"], check=True)
    shipped = simulate_fmu(str(path), stop_time=0.05, output_interval=1e-4, output=["duty_a", "duty_b", "stage"])
    rebuilt = simulate_fmu(str(root), stop_time=0.05, output_interval=1e-4, output=["duty_a", "duty_b", "stage"])
    assert len(shipped) == len(rebuilt) == 501
    for name in ("duty_a", "duty_b", "stage"):
        assert np.array_equal(shipped[name], rebuilt[name]), name
    assert len(set(shipped["duty_a"])) > 10   # the drive did something: polarity pulses
