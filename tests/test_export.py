"""`fullspeed export`: the exported C configuration is the simulator's, byte for byte.

What could be wrong: a float written with too few digits (one ulp off), a
field or a nested block left out or out of order, an enum written as the
wrong constant, a sub-block's table cut short, padding that differs; a
header that changed since the export compiling silently; a configuration
from another library version accepted by fs_drive_init. The exported sources
are compiled with the host cc into one small program that prints the bytes
of each constant, compared with ffi.buffer of the configuration the
simulator builds (fullspeed.sim.build_config, the one fs_sim_create hands to
fs_drive_init).
"""
from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from fullspeed import cli
import re

from fullspeed.model.errors import ConfigError
from fullspeed.workflows.export import c_float, check_name, export
from fullspeed.design.scenario import load_scenario
from fullspeed.sim import build_config, ffi, lib

ROOT = Path(__file__).resolve().parents[1]
CONTROL = ROOT / "csrc" / "control"
CC = shutil.which("cc") or shutil.which("gcc")
needs_cc = pytest.mark.skipif(CC is None, reason="no host C compiler (cc) found")

# one scenario per angle source and converter: SMO, HFI, blend, square wave
# (three and five phases), the matrix converter, the encoder
SCENARIOS = ["yang2022-smo-ramp", "yang2022-hfi-iqstep", "beyond-full-range", "beyond-swvi-3ph",
             "yu2022-seq-dyn", "zou2021-experiment", "yang2022-encoder-speedstep"]


def _compile_and_dump(tmp: Path, names: dict[str, str], include: Path = CONTROL) -> dict[str, bytes]:
    """Compile the exports named {scenario: C name} with a main printing each constant's bytes."""
    main = ["#include <stdio.h>"] + [f'#include "{n}.h"' for n in names.values()]
    main += ["static void dump(const char *tag, const void *p, size_t n) {",
             "    const unsigned char *b = p; printf(\"%s \", tag);",
             "    for (size_t k = 0; k < n; ++k) printf(\"%02x\", b[k]);",
             "    printf(\"\\n\");",
             "}",
             "int main(void) {"]
    main += [f'    dump("{s}", &{n}, sizeof {n});' for s, n in names.items()]
    main += ["    return 0; }"]
    (tmp / "main.c").write_text("\n".join(main) + "\n")
    exe = tmp / "dump"
    srcs = [str(tmp / "main.c")] + [str(tmp / f"{n}.c") for n in names.values()]
    res = subprocess.run([CC, "-std=c11", "-Wall", "-Werror", f"-I{include}", f"-I{tmp}", *srcs, "-o", str(exe)],
                         capture_output=True, text=True)
    if res.returncode != 0:
        raise AssertionError(res.stderr)
    out = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout
    return {ln.split()[0]: bytes.fromhex(ln.split()[1]) for ln in out.splitlines()}


@needs_cc
def test_exported_bytes_equal_the_simulators(tmp_path):
    names = {s: "cfg_" + s.replace("-", "_") for s in SCENARIOS}
    for s, n in names.items():
        export(s, tmp_path, n)
    dumped = _compile_and_dump(tmp_path, names)
    for s in SCENARIOS:
        cfg, _keep = build_config(load_scenario(s))
        want = bytes(ffi.buffer(ffi.addressof(cfg, "drive")))
        got = dumped[s]
        assert len(got) == len(want) == ffi.sizeof("fs_drive_config")
        diff = [k for k in range(len(want)) if got[k] != want[k]]
        assert not diff, f"{s}: bytes differ at offsets {diff[:8]}"
        # the export is not trivially all zeros: the scenario's own values are in it
        assert cfg.drive.config_size == len(want) and cfg.drive.Ts > 0 and cfg.drive.i_max > 0


def test_floats_round_trip_in_float32():
    vals = ffi.new("float[]", [1e-4, 0.036, 6.5e-5, 2617.99390, 1.0 / 3.0, -0.0, 3.0, 1e-38, 3.4e38])
    for k in range(len(vals)):
        text = c_float(vals[k])
        assert text.endswith("f") and any(c in text for c in ".e")
        back = ffi.new("float *", float(text[:-1]))[0]
        assert back == vals[k], text


@needs_cc
def test_a_changed_header_fails_to_compile_naming_the_field(tmp_path):
    """The exported layout is static-asserted: a field inserted since the export is caught."""
    export("yang2022-smo-ramp", tmp_path, "fs_config")
    inc = tmp_path / "control"
    shutil.copytree(CONTROL, inc)
    h = inc / "fs_drive.h"
    text = h.read_text()
    h.write_text(text.replace("    int mode;                /* fs_drive_mode */", "    float added_later;\n    int mode;", 1))
    res = subprocess.run([CC, "-std=c11", f"-I{inc}", f"-I{tmp_path}", "-c", str(tmp_path / "fs_config.c"),
                          "-o", str(tmp_path / "x.o")], capture_output=True, text=True)
    assert res.returncode != 0
    assert "fs_drive_config.mode moved" in res.stderr


def test_init_refuses_a_config_of_another_size():
    cfg, _keep = build_config(load_scenario("yang2022-smo-ramp"))
    drv = ffi.new("fs_drive *")
    assert lib.fs_drive_init(drv, ffi.addressof(cfg, "drive")) == lib.FS_OK
    cfg.drive.config_size += 4
    assert lib.fs_drive_init(drv, ffi.addressof(cfg, "drive")) == lib.FS_ERR_PARAM
    assert ffi.string(drv.fail) == b"config_size"
    cfg.drive.config_size = 0   # hand-written: not checked
    assert lib.fs_drive_init(drv, ffi.addressof(cfg, "drive")) == lib.FS_OK


def test_cli_export_and_bad_name(tmp_path, capsys):
    assert cli.main(["export", "yang2022-hfi-iqstep", "--out", str(tmp_path), "--name", "bench_cfg"]) == 0
    src = (tmp_path / "bench_cfg.c").read_text()
    assert "const fs_drive_config bench_cfg = {" in src and ".angle_source = FS_ANGLE_HFI," in src
    assert "machine yang2022: R_s" in src   # where a value came from
    assert not list(tmp_path.glob("*.tmp"))
    assert cli.main(["export", "yang2022-hfi-iqstep", "--out", str(tmp_path), "--name", "../evil"]) == 2
    assert "--name" in capsys.readouterr().err
    assert cli.main(["export", "no-such-scenario", "--out", str(tmp_path)]) == 2


@pytest.mark.parametrize("name, header", [("memcpy", "string.h"), ("strndup", "string.h"), ("sqrtf", "math.h"),
                                          ("M_PI", "math.h"), ("size_t", "stddef.h"), ("uint8_t", "stdint.h"),
                                          ("FLT_MAX", "float.h"), ("malloc", "stdlib.h"), ("printf", "stdio.h")])
def test_a_c_library_name_is_refused_naming_its_header(name, header):
    with pytest.raises(ConfigError) as err:
        check_name(name)
    assert f"<{header}>" in str(err.value) and str(err.value).startswith(f"--name = {name!r}:")


def test_cli_refuses_memcpy_before_writing(tmp_path, capsys):
    # was exit 0: the header's `extern const fs_drive_config memcpy;` did not compile beside <string.h>
    assert cli.main(["export", "yang2022-hfi-iqstep", "--out", str(tmp_path / "fw"), "--name", "memcpy"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "<string.h>" in err[0] and not (tmp_path / "fw").exists()


def _declared(header: str) -> set[str]:
    """The identifiers the compiler's <header> declares or defines (gnu11, as a firmware
    is built here), without the reserved ones (a leading underscore) and the keywords."""
    src = f"#include <{header}>\n"
    text = subprocess.run([CC, "-E", "-P", "-x", "c", "-"], input=src, capture_output=True, text=True, check=True).stdout
    text = re.sub(r"__attribute__\s*\(\((?:[^()]|\([^()]*\))*\)\)|__asm__\s*\([^)]*\)", "", text)
    names = set(re.findall(r"\b([A-Za-z]\w*)\s*[(;,}=]", text))   # functions, objects, typedefs, enum constants
    given = set(subprocess.run([CC, "-dM", "-E", "-x", "c", "/dev/null"], capture_output=True, text=True).stdout.splitlines())
    macros = subprocess.run([CC, "-dM", "-E", "-x", "c", "-"], input=src, capture_output=True, text=True).stdout
    names |= {line.split()[1].split("(")[0] for line in macros.splitlines() if line not in given}
    keywords = {"char", "const", "double", "float", "int", "long", "short", "signed", "unsigned", "void", "struct",
                "union", "enum", "typedef", "extern", "static", "inline", "restrict", "volatile", "return"}
    return {n for n in names if not n.startswith("_") and n not in keywords}


@needs_cc
@pytest.mark.parametrize("header", ["string.h", "math.h", "float.h", "stdint.h", "stdbool.h", "stddef.h"])
def test_every_name_the_compilers_header_declares_is_refused(header):
    """The refused set is the headers' as the compiler has them, not a handful of their names."""
    accepted = []
    for name in sorted(_declared(header)):
        try:
            check_name(name)
            accepted.append(name)
        except ConfigError:
            pass
    assert not accepted, f"--name accepts what <{header}> declares: {accepted}"


def test_the_firmware_configuration_is_a_fresh_export(tmp_path):
    """firmware/fs_config.[ch] is the export of beyond-full-range, not hand-edited and not stale."""
    export("beyond-full-range", tmp_path, "fs_config")
    for name in ("fs_config.h", "fs_config.c"):
        fresh, kept = (tmp_path / name).read_text(), (ROOT / "firmware" / name).read_text()
        assert kept == fresh, (f"firmware/{name} differs from a fresh export: run "
                               "`fullspeed export beyond-full-range --out firmware --name fs_config`")


@needs_cc
def test_exported_configs_initialise_and_options_refuse_what_they_leave_out(tmp_path):
    """The export through the C library end to end: fs_drive_init accepts each exported
    configuration (config_size included). Built with -DFS_WITH_SWVI=0, the square wave's
    exported source does not compile, naming the option (a firmware built without what its
    drive uses fails on the bench, not at fs_drive_init on the board); the blend's does. A
    configuration compiled apart from the library's options (one not from this export) is
    still refused by fs_drive_init, naming angle_source."""
    names = {"beyond-swvi-3ph": "cfg_swvi", "beyond-full-range": "cfg_blend"}
    for s, n in names.items():
        export(s, tmp_path, n)
    main = ['#include <stdio.h>', '#include "fs_drive.h"'] + [f'#include "{n}.h"' for n in names.values()]
    main += ["static fs_drive drv;", "int main(void) {"]
    main += [f'    {{ int st = (int)fs_drive_init(&drv, &{n}); printf("{n} %d %s\\n", st, drv.fail ? drv.fail : "-"); }}'
             for n in names.values()]
    main += ["    return 0;", "}"]
    (tmp_path / "main.c").write_text("\n".join(main) + "\n")
    srcs = [str(p) for p in sorted(CONTROL.glob("*.c"))]

    def run(flags, cfg_flags):
        objs = []
        for n in names.values():   # each exported source compiled on its own, with cfg_flags
            obj = tmp_path / f"{n}.o"
            subprocess.run([CC, "-std=c11", "-O0", "-c", *cfg_flags, f"-I{CONTROL}", f"-I{tmp_path}", str(tmp_path / f"{n}.c"),
                            "-o", str(obj)], check=True, capture_output=True)
            objs.append(str(obj))
        exe = tmp_path / "init"
        subprocess.run([CC, "-std=c11", "-O0", *flags, f"-I{CONTROL}", f"-I{tmp_path}", str(tmp_path / "main.c"), *srcs,
                        *objs, "-lm", "-o", str(exe)], check=True, capture_output=True)
        out = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout
        return {ln.split()[0]: (int(ln.split()[1]), ln.split()[2]) for ln in out.splitlines()}
    assert run([], []) == {"cfg_swvi": (lib.FS_OK, "-"), "cfg_blend": (lib.FS_OK, "-")}
    no_swvi = ["-DFS_WITH_SWVI=0"]
    for n, fails in (("cfg_swvi", True), ("cfg_blend", False)):
        p = subprocess.run([CC, "-std=c11", "-c", *no_swvi, f"-I{CONTROL}", f"-I{tmp_path}", str(tmp_path / f"{n}.c"),
                            "-o", str(tmp_path / "x.o")], capture_output=True, text=True)
        assert (p.returncode != 0) == fails, p.stderr
        assert ("FS_WITH_SWVI=1" in p.stderr and "square-wave injection" in p.stderr) == fails, p.stderr
    assert run(no_swvi, []) == {"cfg_swvi": (lib.FS_ERR_MODE, "angle_source"), "cfg_blend": (lib.FS_OK, "-")}


def test_export_takes_set_and_says_where_each_value_came_from(tmp_path):
    """--set as run's: the value exported and credited to --set; a value from
    the scenario's machine table credited there; a block the angle source
    does not read marked so; a choice's 0 is the choice, not "designed"."""
    from fullspeed.cli import main
    assert main(["export", "beyond-full-range", "--out", str(tmp_path), "--set", "controller.bw_current=4000",
                 "--set", "machine={catalog = \"yang2022\", bench = {f_pwm = 20000.0}}"]) == 0
    text = (tmp_path / "fs_config.c").read_text()
    line = lambda field: next(ln for ln in text.splitlines() if ln.strip().startswith(f".{field} ="))
    assert "4000.0f" in line("bw_current") and "--set controller.bw_current" in line("bw_current")
    assert "4.99999987e-05f" in line("Ts") and "as the scenario's machine table sets it" in line("Ts")
    assert "not read with controller.angle = blend" in line("sequence")   # the square wave's block
    assert "designed by fs_drive_init" not in line("cc_internal_model") and "[controller] gains" in line("cc_internal_model")
    assert not [ln for ln in text.splitlines() if "..." in ln and not ln.rstrip().endswith("*/")]


def test_an_export_replaces_its_own_files_but_not_a_hand_written_one(tmp_path, capsys):
    """A new user's trial: `fullspeed export SCEN --out DIR` silently replaced a
    hand-written fs_config.c in DIR (new-machine refuses an existing file
    without --force). An earlier export's pair is replaced without asking (the
    README exports into a copy of firmware/, whose pair is an export); any
    other file of those names is refused before either is written, one line
    naming --out, the file and --force, exit 2; --force replaces it."""
    fw = tmp_path / "fw"
    shutil.copytree(ROOT / "firmware", fw)   # fs_config.[ch] there are exports: replaced
    assert cli.main(["export", "yang2022-hfi-iqstep", "--out", str(fw)]) == 0
    assert "yang2022-hfi-iqstep" in (fw / "fs_config.c").read_text()
    pair = {f: (fw / f).read_text() for f in ("fs_config.c", "fs_config.h")}
    mine = "/* my own configuration */\n#include \"fs_config.h\"\n"
    for hand, other in (("fs_config.c", "fs_config.h"), ("fs_config.h", "fs_config.c")):
        for f, text in pair.items():
            (fw / f).write_text(text)
        (fw / hand).write_text(mine)   # either file's refusal keeps both as they were
        capsys.readouterr()
        assert cli.main(["export", "yang2022-smo-ramp", "--out", str(fw)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("fullspeed: error: --out = '"), err
        assert str(fw / hand) in err[0] and "--force" in err[0]
        assert (fw / hand).read_text() == mine and (fw / other).read_text() == pair[other]
        assert not list(fw.glob(".*.tmp*"))
    assert cli.main(["export", "yang2022-smo-ramp", "--out", str(fw), "--force"]) == 0
    assert all("yang2022-smo-ramp" in (fw / f).read_text() for f in ("fs_config.c", "fs_config.h"))
    # an empty file, or one that mentions the banner later, is no export either
    (fw / "fs_config.c").write_text("// " + (fw / "fs_config.c").read_text())
    assert cli.main(["export", "yang2022-smo-ramp", "--out", str(fw)]) == 2
    (fw / "other.c").write_text(mine)   # other names are no concern of the export's
    assert cli.main(["export", "yang2022-smo-ramp", "--out", str(fw), "--name", "other_cfg"]) == 0
    assert (fw / "other.c").read_text() == mine


def test_export_help_and_readme_name_force():
    text = " ".join(cli_help("export").split())
    assert "--force" in text and "not an earlier export's" in text
    readme = (ROOT / "README.md").read_text()
    part = readme[readme.index("## On a microcontroller"):]
    assert "`--force`" in " ".join(part[:part.index("`firmware/` is an image")].split())


def cli_help(cmd: str) -> str:
    import contextlib
    import io
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf), pytest.raises(SystemExit):
        cli.main([cmd, "--help"])
    return buf.getvalue()
