"""--set key=value on run and sweep: dotted scenario keys, TOML values."""
import json
from pathlib import Path

import pytest

from fullspeed.cli import _set_overrides, main
from fullspeed.model.errors import ConfigError

ROOT = Path(__file__).resolve().parents[1]


def test_set_parses_dotted_keys_and_toml_values():
    o = _set_overrides(["controller.bw_speed=50", "references.speed_rpm=[[0, 0], [0.1, 1000]]",
                        "controller.angle=blend", "controller.flux_weakening=true", 'machine.name="a=b"'])
    assert o == {"controller": {"bw_speed": 50, "angle": "blend", "flux_weakening": True},
                 "references": {"speed_rpm": [[0, 0], [0.1, 1000]]}, "machine": {"name": "a=b"}}
    for bad in ("controller.bw_speed", "=3", "controller..x=1", "references.i_q=[1, 2", "controller.angle="):
        with pytest.raises(ConfigError):
            _set_overrides([bad])


def test_run_with_set_changes_the_scenario(tmp_path, capsys):
    rc = main(["run", "yang2022-encoder-speedstep", "--quiet", "--out", str(tmp_path),
               "--set", "duration=0.3", "--set", "metrics.steady=[0.2, 0.3]", "--set", "references.speed_rpm=500.0"])
    assert rc == 0
    m = json.loads((tmp_path / "metrics.json").read_text())
    assert m["steady_window"] == [0.2, 0.3] and abs(m["speed_ref_rpm"] - 500.0) < 1e-3
    assert main(["run", "yang2022-encoder-speedstep", "--quiet", "--out", str(tmp_path), "--set", "controller.angle=blnd"]) == 2
    assert "controller.angle = 'blnd'" in capsys.readouterr().err


def test_sweep_with_set_adds_to_its_overrides(tmp_path, capsys):
    f = tmp_path / "s.toml"
    f.write_text('name = "s"\nbase = "yang2022-encoder-speedstep"\nmetrics = ["speed_rpm"]\n'
                 '[overrides]\nduration = 0.2\nmetrics = { steady = [0.15, 0.2] }\n'
                 '[axes]\n"references.speed_rpm" = [300.0, 600.0]\n')
    assert main(["sweep", str(f), "--quiet", "--workers", "1", "--out", str(tmp_path / "o"),
                 "--set", "controller.bw_speed=40"]) == 0
    assert main(["sweep", str(f), "--quiet", "--workers", "1", "--out", str(tmp_path / "p"),
                 "--set", "controller.bw_speed=-1"]) == 2
    assert "controller.bw_speed" in capsys.readouterr().err


def test_set_on_a_named_machines_field_merges_into_that_machine():
    """--set machine.bench.f_pwm on a scenario whose machine is a catalog
    name or a machine file: that machine with the one field changed (it
    replaced the name with a one-field table, which then missed every
    required field)."""
    from fullspeed.design.scenario import load_scenario
    ov = _set_overrides(["machine.bench.f_pwm=20000"])
    sc = load_scenario("beyond-full-range", ov)
    base = load_scenario("beyond-full-range")
    assert sc.machine.name == "yang2022" and sc.machine.bench["f_pwm"] == 20000.0
    assert sc.data["converter"]["f_pwm"] == 20000.0 and sc.machine.L_d == base.machine.L_d
    assert {k: v for k, v in sc.machine.bench.items() if k != "f_pwm"} == \
        {k: v for k, v in base.machine.bench.items() if k != "f_pwm"}
    own = ROOT / "examples" / "own-machine" / "my48v-full-range.toml"
    sc = load_scenario(str(own), ov)   # its flux map beside the machine file, found from the merged table too
    assert sc.machine.name == "my48v" and sc.machine.bench["f_pwm"] == 20000.0 and sc.machine.magnetic["model"] == "fluxmap"
