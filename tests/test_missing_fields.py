"""Required fields left out, or left "?" from `fullspeed new-machine`'s
template, are refused all at once: one line naming each with its unit and
range, exit 2, before anything runs. Other bad values keep their own
one-field message."""
import os
import subprocess
import sys
import tomllib

import pytest

from fullspeed.model.errors import ConfigError, MissingFields
from fullspeed.design.machine import load_machine
from fullspeed.model.machines import MACHINE
from fullspeed.model.reference import machine_template
from fullspeed.design.scenario import load_scenario, scenario_from_dict
from fullspeed.model.scenario import SCENARIO
from fullspeed.model.schema import MISSING

# the 48 V IPMSM of the new-user trial, by dotted field of the machine file
DATASHEET = {"name": "my48v", "kind": "ipmsm", "pole_pairs": 4, "electrical.R_s": 0.025, "electrical.L_d": 0.30e-3,
             "electrical.L_q": 0.75e-3, "electrical.psi_f": 0.0105, "mechanical.J": 5e-4,
             "rated.torque": 3.0, "rated.current": 28.0, "rated.speed_rpm": 3000.0,
             "bench.u_dc": 48.0, "bench.f_pwm": 20000.0}


def _required(table: dict, prefix: str) -> set[str]:
    """Every required leaf of a schema table, dotted (a required table: its required fields)."""
    out = set()
    for k, s in table.items():
        if s.default is MISSING:
            out |= _required(s.table, f"{prefix}{k}.") if s.kind == "table" else {f"{prefix}{k}"}
    return out


MACHINE_REQUIRED = _required(MACHINE, "machine.")


def _nested(flat: dict) -> dict:
    d = {}
    for dotted, v in flat.items():
        *tables, key = dotted.split(".")
        t = d
        for k in tables:
            t = t.setdefault(k, {})
        t[key] = v
    return d


def _named(msg: str, fields: set[str]) -> set[str]:
    """The fields of `fields` the message names (each as 'field (unit ...)')."""
    return {f for f in fields if f"{f} (" in msg}


def _refusal(path) -> MissingFields:
    with pytest.raises(MissingFields) as exc:
        load_machine(path)
    msg = str(exc.value)
    assert "\n" not in msg and msg.startswith(f"{path}: ")
    return exc.value


def test_the_datasheet_is_every_required_field():
    assert {f"machine.{k}" for k in DATASHEET} == MACHINE_REQUIRED


@pytest.mark.parametrize("left_out", [
    ["rated.torque"],
    ["electrical.R_s", "bench.f_pwm"],
    sorted(DATASHEET),                       # all of them: an empty file
], ids=["one", "two", "all"])
def test_missing_fields_are_named_together_with_unit_and_range(tmp_path, left_out):
    path = tmp_path / "my48v.toml"
    path.write_text("".join(f"{k} = {v!r}\n" for k, v in DATASHEET.items() if "." not in k and k not in left_out)
                    .replace("'", '"') + "\n", encoding="utf-8")
    given = _nested({k: v for k, v in DATASHEET.items() if "." in k and k not in left_out})
    with path.open("a", encoding="utf-8") as f:
        for table, fields in given.items():
            f.write(f"[{table}]\n" + "".join(f"{k} = {v!r}\n" for k, v in fields.items()))
    err = _refusal(path)
    expected = {f"machine.{k}" for k in left_out}
    msg = str(err)
    assert _named(msg, MACHINE_REQUIRED) == expected
    assert {e[1] for e in err.entries} == expected and len(err.entries) == len(left_out)
    assert msg.startswith(f"{path}: missing required fields: ") and '"?"' not in msg
    if "rated.torque" in left_out:
        assert "machine.rated.torque (N m; > 0 and <= 1e+06)" in msg
    if "bench.f_pwm" in left_out:
        assert "machine.bench.f_pwm (Hz; >= 100 and <= 1e+06)" in msg
    if "kind" in left_out:
        assert 'machine.kind ("ipmsm" or "spmsm")' in msg


def _template_with(tmp_path, filled: list[str]):
    text = machine_template("my48v")
    for dotted in filled:   # the template's line `key = "?"` in its table, filled in
        *tables, key = dotted.split(".")
        head = f"[{tables[0]}]\n" if tables else ""
        start = text.index(head) if head else 0
        at = text.index(f'\n{key} = "?"', start) + 1
        value = DATASHEET[dotted]
        text = text[:at] + f"{key} = {value!r}".replace("'", '"') + text[at + len(f'{key} = "?"'):]
    assert tomllib.loads(text)["name"] == "my48v"
    path = tmp_path / "my48v.toml"
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize("n_left", [1, 2, "all"])
def test_placeholders_left_from_the_template_are_named_together(tmp_path, n_left):
    asked = [k for k in DATASHEET if k != "name"]           # the template writes the name
    left = asked if n_left == "all" else asked[3:3 + n_left]
    path = _template_with(tmp_path, [k for k in asked if k not in left])
    err = _refusal(path)
    msg = str(err)
    assert msg.startswith(f'{path}: required fields left "?": ') and "missing" not in msg
    assert _named(msg, MACHINE_REQUIRED) == {f"machine.{k}" for k in left}
    assert all(e[3] for e in err.entries)


def test_the_filled_template_is_accepted(tmp_path):
    m = load_machine(_template_with(tmp_path, [k for k in DATASHEET if k != "name"]))
    assert m.pole_pairs == 4 and m.L_q == 0.75e-3


def test_missing_and_left_fields_in_one_line(tmp_path):
    path = _template_with(tmp_path, [k for k in DATASHEET if k not in ("name", "pole_pairs", "rated.current")])
    path.write_text(path.read_text(encoding="utf-8").replace("\nJ = 0.0005", "\n"), encoding="utf-8")
    msg = str(_refusal(path))
    assert msg.startswith(f"{path}: missing required fields: machine.mechanical.J (kg m^2; ")
    assert '; required fields left "?": ' in msg
    assert _named(msg, MACHINE_REQUIRED) == {"machine.mechanical.J", "machine.pole_pairs", "machine.rated.current"}


def test_a_bad_value_keeps_its_own_message(tmp_path):
    path = _template_with(tmp_path, [k for k in DATASHEET if k not in ("name", "rated.current")])
    path.write_text(path.read_text(encoding="utf-8").replace("R_s = 0.025", "R_s = -1.0"), encoding="utf-8")
    with pytest.raises(ConfigError) as exc:
        load_machine(path)
    assert not isinstance(exc.value, MissingFields)
    assert exc.value.field == "machine.electrical.R_s" and str(exc.value).startswith(f"{path}: machine.electrical.R_s = -1.0: ")


def test_a_scenario_names_its_own_and_its_inline_machines_missing_fields():
    machine = _nested({k: v for k, v in DATASHEET.items() if k not in ("electrical.psi_f", "rated.speed_rpm")})
    machine["bench"]["f_pwm"] = "?"
    with pytest.raises(MissingFields) as exc:
        scenario_from_dict({"name": "s", "machine": machine, "controller": {"angle": "blend"}}, "s.toml")
    msg = str(exc.value)
    assert "\n" not in msg and msg.startswith("s.toml: missing required fields: ")
    assert _named(msg, _required(SCENARIO, "") | MACHINE_REQUIRED) == {
        "duration", "controller.mode", "machine.electrical.psi_f", "machine.rated.speed_rpm", "machine.bench.f_pwm"}
    assert 'left "?": machine.bench.f_pwm (Hz; ' in msg


def test_a_scenario_without_a_machine_or_controller():
    with pytest.raises(MissingFields) as exc:
        scenario_from_dict({"name": "s", "duration": 1.0}, "s.toml")
    assert _named(str(exc.value), _required(SCENARIO, "")) == {"machine", "controller.mode"}


def test_a_scenario_and_its_machine_file_each_named_with_their_file(tmp_path):
    _template_with(tmp_path, [k for k in DATASHEET if k not in ("name", "electrical.R_s")])
    sc = tmp_path / "run.toml"
    sc.write_text('name = "run"\nmachine = "my48v.toml"\n[controller]\nmode = "speed"\n', encoding="utf-8")
    with pytest.raises(MissingFields) as exc:
        load_scenario(sc)
    assert str(exc.value) == (f"{sc}: missing required fields: duration (s; > 0 and <= 10000); "
                              f'{tmp_path / "my48v.toml"}: required fields left "?": machine.electrical.R_s (ohm; >= 0 and <= 1000)')


def test_the_command_line_refuses_with_exit_2_before_any_work(tmp_path):
    _template_with(tmp_path, [k for k in DATASHEET if k not in ("name", "rated.torque", "bench.u_dc")])
    sc = tmp_path / "run.toml"
    sc.write_text('name = "run"\nduration = 0.1\nmachine = "my48v.toml"\n[controller]\nmode = "speed"\n', encoding="utf-8")
    out = tmp_path / "out"
    p = subprocess.run([sys.executable, "-m", "fullspeed", "run", str(sc), "--out", str(out), "--quiet"],
                       capture_output=True, text=True, timeout=120, env={**os.environ, "PYTHONWARNINGS": "ignore"})
    assert p.returncode == 2 and not out.exists()
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and _named(lines[0], MACHINE_REQUIRED) == {"machine.rated.torque", "machine.bench.u_dc"}


def test_config_errors_cross_a_process_boundary_whole():
    """A ConfigError raised in a worker process reaches the parent with its
    field, value and message (a pool unpickles it; the default pickle gave
    the message alone to an __init__ that needs three arguments)."""
    import pickle
    from concurrent.futures import ProcessPoolExecutor

    from fullspeed.workflows.calibrate import CalibrationError
    errors = [ConfigError("controller.i_max", -3.0, "must be > 0 A", "s.toml"),
              CalibrationError("calibration", "hfi", "the speed left its band"),
              MissingFields([("m.toml", "machine.R_s", "Ohm; > 0", False), ("m.toml", "machine.kind", "", True)], "in m.toml")]
    for e in errors:
        back = pickle.loads(pickle.dumps(e))
        assert type(back) is type(e) and str(back) == str(e)
        assert (back.field, back.value, back.allowed, back.source) == (e.field, e.value, e.allowed, e.source)
    with ProcessPoolExecutor(1) as pool:
        with pytest.raises(ConfigError, match="controller.i_max = -3.0: must be > 0 A"):
            pool.submit(_raise, errors[0]).result()


def _raise(exc):
    raise exc


def test_a_designed_value_in_a_refusal_reads_as_a_number_not_as_float_noise():
    """B-REAL's H27 refusal read "observer.i_start = 4.800000000000001"
    (1.2 x 4 A, formed by the design); a value as a user writes it stays."""
    from fullspeed.model.errors import ConfigError
    assert str(ConfigError("observer.i_start", 1.2 * 4.0, "x")) == "observer.i_start = 4.8: x"
    assert str(ConfigError("a", 0.1 + 0.2, "x")) == "a = 0.3: x"
    for given in (3.0, 1e-320, 0.125, -2.5e-07):
        assert str(ConfigError("a", given, "x")) == f"a = {given!r}: x"
