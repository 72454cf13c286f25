"""Flux maps from files: a CSV (one row per (i_d, i_q)) or the MATLAB .mat
layout of SyR-e that motulator reads, resampled to the even grid the plant
interpolates on (fs_magnetic.h), with where the data came from recorded;
checked against the current limit (coverage) and against [electrical]
(consistency).

CSV: a header row naming the columns with their units, in brackets or
parentheses: `i_d [A], i_q [A], psi_d [Wb], psi_q [Wb], T [N m]` (torque
optional; `id`, `psid`, `torque`, `Vs`, `mWb`, `Nm` are understood too), then
one row per point of a full grid (every i_d with every i_q; the steps may be
uneven). Lines starting with # are comments.

.mat (needs scipy): `motorModel.FluxMap_dq` with the matrices Id, Iq, Fd, Fq
(and T), or the same matrices at the top level (SyR-e's idiq_fdfq files).
SyR-e puts the magnet on the -q axis; the map is turned to the PMSM
convention (magnet on +d): i_d = -Iq, i_q = Id, psi_d = -Fq, psi_q = Fd.

A map given for i_q >= 0 only is completed by the machine's symmetry:
psi_d(i_d, -i_q) = psi_d(i_d, i_q), psi_q(i_d, -i_q) = -psi_q(i_d, i_q).
"""
from __future__ import annotations

import csv
import hashlib
import math
import struct
import zlib
from pathlib import Path

import numpy as np

from .errors import ConfigError
from .files import path_kind, read_bounded, read_text   # a regular file, bounded (a FIFO or /dev/zero is refused)

# column name -> the names it may have in a file (lower case, no spaces)
COLUMNS = {"i_d": ("i_d", "id"), "i_q": ("i_q", "iq"), "psi_d": ("psi_d", "psid", "fd", "flux_d"),
           "psi_q": ("psi_q", "psiq", "fq", "flux_q"), "torque": ("torque", "t", "t_e", "te")}
# unit -> factor to SI, by the quantity's SI unit
UNITS = {"A": {"a": 1.0, "ka": 1e3, "ma": 1e-3},
         "Wb": {"wb": 1.0, "vs": 1.0, "mwb": 1e-3, "mvs": 1e-3},
         "N m": {"nm": 1.0, "n.m": 1.0, "n*m": 1.0}}
SI = {"i_d": "A", "i_q": "A", "psi_d": "Wb", "psi_q": "Wb", "torque": "N m"}
MAX_POINTS = 1000            # per axis, as the machine file's map (machines._check_fluxmap)
MAX_MAT_UNPACKED = 256 * 2**20   # B: a .mat map's variables decompressed (SyR-e's motorModel is a few MB)
MAT_VARIABLES = ("motorModel", "Id", "Iq", "Fd", "Fq", "T")   # all a map is read from

# [electrical] against the map at zero current: the magnet's flux is what a
# datasheet's back-EMF constant gives, to a few %; the inductances are given
# at some current the datasheet may not say (saturation moves them 20..40 %)
PSI_F_TOL = 0.10
L_TOL = 0.35
TORQUE_TOL = 0.10            # the file's torque against 1.5 p (psi_d i_q - psi_q i_d), median over the map
# [electrical] and the map more than this factor apart describe two machines, not one measured twice (the
# catalog's maps agree with their files within 3 %; the new-user trial's psi_f in mWb written as Wb was
# 1000 x off, warned, and the run failed on a cause the warning did not name): refused
GROSS_FACTOR = 2.0


class FluxMapWarning(UserWarning):
    """[electrical] and the flux map disagree (one line: the plant follows the map)."""


def _split_header(name: str) -> tuple[str, str] | None:
    """'psi_d [mWb]' -> ('psi_d', 'mWb'); 'i_d' -> ('i_d', ''); None for a
    name that is not `words [unit]` or `words (unit)`. One scan of the text
    (a regular expression for this backtracks: cubic in a run of spaces)."""
    s = name.strip()
    k = next((i for i, ch in enumerate(s) if ch in "[("), -1)
    if k < 0:
        return (s, "") if s else None
    base, rest = s[:k].strip(), s[k + 1:]
    if not base or not rest or rest[-1] not in "])" or any(ch in "])" for ch in rest[:-1]):
        return None
    return base, rest[:-1].strip()


def _header(name: str, field: str, source) -> tuple[str, float]:
    """'psi_d [mWb]' -> ('psi_d', 1e-3)."""
    m = _split_header(name)
    base = m[0].lower().replace(" ", "") if m else name
    col = next((k for k, names in COLUMNS.items() if base in names), None)
    if col is None:
        return "", 0.0   # a column this reader does not use
    unit = m[1].lower().replace(" ", "")
    if not unit:
        raise ConfigError(field, name, f"needs its unit in the header, e.g. '{col} [{SI[col]}]'", source)
    factor = UNITS[SI[col]].get(unit)
    if factor is None:
        raise ConfigError(field, name, f"unit must be one of {', '.join(UNITS[SI[col]])} (case-insensitive) for {col}", source)
    return col, factor


def read_csv(path: Path, field: str, source=None) -> dict[str, np.ndarray]:
    """The columns of a flux-map CSV, in SI, as flat arrays."""
    text = read_text(path, field, source).removeprefix("\ufeff")   # the byte-order mark of Excel's "CSV UTF-8"
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    try:
        rows = list(csv.reader(lines))
    except csv.Error as exc:   # a field over csv's limit (131,072 characters), a NUL
        raise ConfigError(field, str(path), f"is not a flux-map CSV: {exc}", source) from None
    if len(rows) < 5:
        raise ConfigError(field, str(path), "must hold a header and at least 4 rows (a 2 x 2 grid)", source)
    cols = [_header(h, field, source) for h in rows[0]]
    have = {c for c, _ in cols}
    missing = [c for c in ("i_d", "i_q", "psi_d", "psi_q") if c not in have]
    if missing:
        header = ", ".join(rows[0])
        header = header if len(header) <= 120 else header[:117] + "..."
        raise ConfigError(field, str(path), f"has no column {', '.join(missing)} (header: {header})", source)
    out: dict[str, list] = {c: [] for c in have if c}
    for n, row in enumerate(rows[1:], start=2):
        if len(row) != len(cols):
            raise ConfigError(f"{field} line {n}", row, f"must have {len(cols)} values like the header", source)
        for (c, f), v in zip(cols, row):
            if not c:
                continue
            try:
                x = float(v)
            except ValueError:
                raise ConfigError(f"{field} line {n}", v, f"{c} must be a number", source) from None
            if not math.isfinite(x):
                raise ConfigError(f"{field} line {n}", v, f"{c} must be finite", source)
            out[c].append(x * f)
    return {c: np.asarray(v) for c, v in out.items()}


def _mat5_name(head: bytes, order: str) -> str | None:
    """The name of a MAT 5 matrix element from its first bytes (the tag,
    the array flags, the dimensions, the name), or None before it is whole."""
    def tag(at: int):
        if len(head) < at + 8:
            return None
        kind, size = struct.unpack_from(order + "II", head, at)
        if kind >> 16:   # the small element format: the size in the upper half, the data in the tag
            return kind & 0xFFFF, kind >> 16, at + 4, at + 8
        return kind, size, at + 8, at + 8 + (size + 7) // 8 * 8
    at = 8   # past the matrix's own tag
    for _ in range(2):   # array flags, dimensions
        t = tag(at)
        if t is None:
            return None
        at = t[3]
    t = tag(at)
    if t is None or len(head) < t[2] + t[1]:
        return None
    return head[t[2]:t[2] + t[1]].decode("latin1")


def _mat_variables(data: bytes, names: tuple[str, ...], field: str, path: Path, source) -> list[str]:
    """Which of `names` a MATLAB file holds, having checked that they take at
    most MAX_MAT_UNPACKED bytes once decompressed (a compressed variable of
    zeros grows a thousandfold: 6 MB of file, 6 GB of memory): one pass over
    the file's elements, the others decompressed only as far as their name.
    Version 4 files are not compressed: their size is bounded by the file's."""
    from io import BytesIO

    from scipy.io.matlab import matfile_version

    if matfile_version(BytesIO(data))[0] != 1:   # 0: version 4; 2: HDF5 (v7.3), which loadmat refuses
        return list(names)
    order = "<" if data[126:128] == b"IM" else ">"
    found, left, at = [], MAX_MAT_UNPACKED, 128
    while at + 8 <= len(data) and left >= 0:
        kind, size = struct.unpack_from(order + "II", data, at)
        body, at = data[at + 8:at + 8 + size], at + 8 + size
        if kind != 15:   # not miCOMPRESSED: its bytes are in the file, bounded by its size
            name = _mat5_name(data[at - size - 8:at], order)
            if name in names:
                found.append(name)
                left -= size
            continue
        z, rest, head, name = zlib.decompressobj(), body, b"", None
        try:
            while rest and not z.eof and left >= 0:
                chunk = z.decompress(rest, 4096 if name is None else 2**24)   # the name first, then in 16 MiB pieces
                rest = z.unconsumed_tail
                if name is None:
                    head += chunk[:4096]
                    name = _mat5_name(head, order)
                    if name is not None and name not in names:
                        break   # not read: loadmat skips it (variable_names)
                    if name is not None:
                        found.append(name)
                if name is not None:
                    left -= len(chunk)
        except zlib.error:
            break   # loadmat says what is wrong with it
    if left < 0:
        raise ConfigError(field, str(path), f"holds more than {MAX_MAT_UNPACKED // 2**20} MiB of data once decompressed in "
                          f"the variables a flux map is read from ({', '.join(found)}); a map takes a few MB", source)
    return found


def read_mat(path: Path, field: str, source=None) -> dict[str, np.ndarray]:
    """A SyR-e map (.mat), turned to the PMSM convention, as flat arrays: the
    file at most MAX_TOML_BYTES, only the variables a map is read from
    decompressed, and those at most MAX_MAT_UNPACKED bytes."""
    from io import BytesIO

    try:
        from scipy.io import loadmat
    except ImportError:
        raise ConfigError(field, str(path), "reading a .mat flux map needs scipy (pip install scipy); or give the map as CSV", source) from None
    data = read_bounded(path, field, source)
    try:
        names = _mat_variables(data, MAT_VARIABLES, field, path, source)
        mat = loadmat(BytesIO(data), variable_names=names)
    except ConfigError:
        raise
    except Exception as exc:   # scipy raises several kinds for a bad file
        why = " ".join(str(exc).split())[:160] or "no reason given"
        raise ConfigError(field, str(path), f"is not a MATLAB file scipy can read: {type(exc).__name__}: {why}", source) from None
    if "motorModel" in mat:
        try:
            fm = mat["motorModel"][0, 0]["FluxMap_dq"][0, 0]
            fm["Id"]   # a structure, not a number
            get = lambda k: fm[k]   # noqa: E731
        except (KeyError, ValueError, IndexError, TypeError):
            raise ConfigError(field, str(path), "has a motorModel without FluxMap_dq (Id, Iq, Fd, Fq)", source) from None
    else:
        get = lambda k: mat[k]   # noqa: E731
    out = {}
    for col, key, sign in (("i_d", "Iq", -1.0), ("i_q", "Id", 1.0), ("psi_d", "Fq", -1.0), ("psi_q", "Fd", 1.0),
                           ("torque", "T", 1.0)):
        try:
            raw = get(key)
        except (KeyError, ValueError, IndexError, TypeError):
            if col == "torque":
                continue
            raise ConfigError(field, str(path), "must hold Id, Iq, Fd and Fq (SyR-e's FluxMap_dq or idiq_fdfq layout)", source) from None
        out[col] = sign * _mat_array(raw, key, field, path, source)
    sizes = {k: v.size for k, v in out.items()}
    if len(set(sizes.values())) != 1:
        raise ConfigError(field, str(path), "Id, Iq, Fd, Fq (and T) must have as many values each: "
                          + ", ".join(f"{k} {n}" for k, n in sizes.items()), source)
    return out


def _mat_array(raw, key: str, field: str, path: Path, source) -> np.ndarray:
    """One matrix of a .mat map as finite real numbers, flat."""
    a = np.asarray(raw)
    if a.dtype.kind not in "biuf" or a.size > MAX_POINTS**2:
        what = f"{a.size} values" if a.dtype.kind in "biuf" else f"of type {a.dtype}"
        raise ConfigError(f"{field} {key}", what, f"must be a real matrix of at most {MAX_POINTS} x {MAX_POINTS} numbers", source)
    a = a.astype(float).ravel()
    if not np.isfinite(a).all():
        raise ConfigError(f"{field} {key}", str(path), "must be finite (it holds NaN or infinite values)", source)
    return a


def _grid(cols: dict[str, np.ndarray], field: str, source) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    """Flat columns of a full grid as axes and tables [k][l] at (i_d[k], i_q[l])."""
    i_d, i_q = np.unique(cols["i_d"]), np.unique(cols["i_q"])
    if not (2 <= i_d.size <= MAX_POINTS and 2 <= i_q.size <= MAX_POINTS):
        raise ConfigError(field, f"{i_d.size} x {i_q.size} currents", f"must be 2..{MAX_POINTS} distinct values per axis", source)
    if cols["i_d"].size != i_d.size * i_q.size:
        raise ConfigError(field, f"{cols['i_d'].size} points", f"must be a full grid: every i_d with every i_q "
                          f"({i_d.size} x {i_q.size} = {i_d.size * i_q.size} points, each once)", source)
    k, n = np.searchsorted(i_d, cols["i_d"]), np.searchsorted(i_q, cols["i_q"])
    seen = np.zeros((i_d.size, i_q.size), bool)
    seen[k, n] = True
    if not seen.all():
        raise ConfigError(field, "grid", "must be a full grid: some (i_d, i_q) pair appears twice and another not at all", source)
    tabs = {}
    for c in ("psi_d", "psi_q", "torque"):
        if c in cols:
            t = np.empty((i_d.size, i_q.size))
            t[k, n] = cols[c]
            tabs[c] = t
    return i_d, i_q, tabs


def _mirror_q(i_q: np.ndarray, tabs: dict) -> tuple[np.ndarray, dict]:
    """Complete a map given for i_q >= 0 by the symmetry about the d axis."""
    neg = i_q[::-1][:-1] * -1 if i_q[0] == 0.0 else -i_q[::-1]
    sign = {"psi_d": 1.0, "psi_q": -1.0, "torque": -1.0}
    cut = 1 if i_q[0] == 0.0 else 0
    return (np.r_[neg, i_q],
            {c: np.concatenate([sign[c] * t[:, cut:][:, ::-1], t], axis=1) for c, t in tabs.items()})


def _even(axis: np.ndarray) -> np.ndarray:
    return np.linspace(axis[0], axis[-1], axis.size)


def resample(i_d: np.ndarray, i_q: np.ndarray, tabs: dict) -> tuple[np.ndarray, np.ndarray, dict]:
    """Tables on a rectilinear grid onto the even grid with as many points
    over the same ranges: bilinear, along i_q within each row, then along
    i_d within each column (exact where the grid was even already)."""
    e_d, e_q = _even(i_d), _even(i_q)
    out = {}
    for c, t in tabs.items():
        rows = np.array([np.interp(e_q, i_q, r) for r in t])
        out[c] = np.array([np.interp(e_d, i_d, col) for col in rows.T]).T
    return e_d, e_q, out


# load_map's maps by file (its path, size and modification time) and the field and source its errors name,
# the LOADED_KEEP most recent: B-REAL loads its three maps' machines about 150 times (each a CSV read, resampled
# and hashed), the same file each time. A file written since is read again.
LOADED_KEEP = 16
_LOADED: dict = {}


def load_map(path: str | Path, field: str, source=None) -> dict:
    """A flux-map file as [magnetic] fields: model, i_d, i_q, psi_d, psi_q
    (even grids, rows in i_d), torque where given, and source (a copy of
    the map read before where the file has not changed since)."""
    p = Path(path)
    try:
        st = p.stat()
        key = (str(p.resolve()), st.st_mtime_ns, st.st_size, st.st_ino, field, str(source))
    except OSError:
        key = None   # not there, or not to be looked at: _read_map says why
    if key is None or key not in _LOADED:
        out = _read_map(p, field, source)
        if key is None:
            return out
        _LOADED[key] = out
        while len(_LOADED) > LOADED_KEEP:
            del _LOADED[next(iter(_LOADED))]
    # a copy of the lists (the numbers are immutable): a deepcopy of the ~15,000 of a map was half its read
    return {k: ([row[:] for row in v] if v and isinstance(v[0], list) else v[:]) if isinstance(v, list) else v
            for k, v in _LOADED[key].items()}


def _read_map(p: Path, field: str, source) -> dict:
    kind = path_kind(p)
    if kind is None:
        raise ConfigError(field, str(p), "file not found", source)
    if kind != "file":
        raise ConfigError(field, str(p), "is a folder, not a flux map" if kind == "dir" else
                          "is not a regular file (a device, FIFO or socket); give the map's file", source)
    reader = {".csv": read_csv, ".mat": read_mat}.get(p.suffix.lower())
    if reader is None:
        raise ConfigError(field, str(p), "must be a .csv or a .mat (SyR-e) flux map", source)
    cols = reader(p, field, source)
    i_d, i_q, tabs = _grid(cols, field, source)
    notes = [f"{i_d.size} x {i_q.size} points, i_d {i_d[0]:g}..{i_d[-1]:g} A, i_q {i_q[0]:g}..{i_q[-1]:g} A"]
    if i_q[0] >= 0.0:
        i_q, tabs = _mirror_q(i_q, tabs)
        notes.append("negative i_q by symmetry")
    uneven = not (np.allclose(np.diff(i_d), i_d[1] - i_d[0], rtol=1e-6) and np.allclose(np.diff(i_q), i_q[1] - i_q[0], rtol=1e-6))
    if uneven:
        notes.append("resampled bilinearly to an even grid")
    i_d, i_q, tabs = resample(i_d, i_q, tabs)
    _check_orientation(i_d, i_q, tabs, field, str(p), source)
    digest = hashlib.sha256(read_bounded(p, field, source)).hexdigest()[:12]
    out = {"model": "fluxmap", "i_d": i_d.tolist(), "i_q": i_q.tolist(),
           "psi_d": tabs["psi_d"].tolist(), "psi_q": tabs["psi_q"].tolist(),
           "source": f"{p.name} (sha256 {digest}): " + "; ".join(notes)}
    if "torque" in tabs:
        out["torque"] = tabs["torque"].tolist()
    return out


# The magnet's flux at zero current off +d by more than this share of the map's
# largest flux is a map in another convention, not a measurement's offset (the
# Baldor's measured map: psi_q(0, 0) = 0; a remanence or an integrator's drift
# stays at a few per cent)
ORIENTATION_TOL = 0.05


def _check_orientation(i_d, i_q, tabs: dict, field: str, path: str, source) -> None:
    """The project's convention puts the magnet on +d (amplitude-invariant
    dq, L_d the magnet's axis): a map whose flux at zero current lies on q
    or on -d (a SyR-e CSV, a PM-SyRM named the other way) is refused naming
    where it lies and the turn that mends it."""
    mag = {"i_d": i_d, "i_q": i_q, **tabs}
    psi_d0, psi_q0 = table_at(mag, "psi_d", 0.0, 0.0), table_at(mag, "psi_q", 0.0, 0.0)
    scale = max(float(np.max(np.abs(tabs["psi_d"]))), float(np.max(np.abs(tabs["psi_q"]))), 1e-12)
    if abs(psi_q0) > ORIENTATION_TOL * scale and abs(psi_q0) > abs(psi_d0):
        where, turn = ("+q", "i_d, psi_d <- i_q, psi_q and i_q, psi_q <- -i_d, -psi_d") if psi_q0 > 0 else \
                      ("-q", "i_d, psi_d <- -i_q, -psi_q and i_q, psi_q <- i_d, psi_d")
    elif psi_d0 < -ORIENTATION_TOL * scale:
        where, turn = "-d", "i_d, psi_d <- -i_d, -psi_d and i_q, psi_q <- -i_q, -psi_q"
    else:
        return
    raise ConfigError(field, path, f"at zero current its flux lies on {where} (psi_d {psi_d0:.4g} Wb, psi_q {psi_q0:.4g} Wb), "
                      f"{100 * max(abs(psi_d0), abs(psi_q0)) / scale:.0f} % of its largest: the magnet must lie on +d "
                      f"(the magnet's axis is d here, as in the PMSM convention): turn the map's frame, {turn}", source)


def interp(mag: dict, name: str, i_d, i_q):
    """A map's table at currents (arrays or numbers; bilinear on its even
    grid, held at the edges as the plant's lookup is not: the callers stay
    inside the map)."""
    return interp_tables(mag, (name,), i_d, i_q)[0]


def interp_tables(mag: dict, names: tuple[str, ...], i_d, i_q) -> list:
    """interp of each of the named tables at the same currents, the cell
    and its weights found once (the design's searches read psi_d and psi_q
    together, hundreds of thousands of times a campaign): each value the
    same to the bit as interp's alone."""
    e_d, e_q = np.asarray(mag["i_d"]), np.asarray(mag["i_q"])
    x = np.clip((np.asarray(i_d, float) - e_d[0]) / (e_d[1] - e_d[0]), 0.0, e_d.size - 1.0)
    y = np.clip((np.asarray(i_q, float) - e_q[0]) / (e_q[1] - e_q[0]), 0.0, e_q.size - 1.0)
    k, n = np.minimum(x.astype(int), e_d.size - 2), np.minimum(y.astype(int), e_q.size - 2)
    a, b = x - k, y - n
    # the corners' weights, each product as the sum below had it ((1 - a) * (1 - b), then times the
    # table's value), made once for every table; the corners read from the flat table (cell k, n at
    # k * cols + n): the same values as t[k, n], fewer passes over the arrays
    w00, w10, w01, w11 = (1 - a) * (1 - b), a * (1 - b), (1 - a) * b, a * b
    cols = e_q.size
    c00 = k * cols + n
    c10, c01, c11 = c00 + cols, c00 + 1, c00 + cols + 1
    out = []
    for name in names:
        t = np.asarray(mag[name]).ravel()
        out.append(w00 * t.take(c00) + w10 * t.take(c10) + w01 * t.take(c01) + w11 * t.take(c11))
    return out


def table_at(mag: dict, name: str, i_d: float, i_q: float) -> float:
    """One value of a map's table (interp at a point)."""
    return float(interp(mag, name, i_d, i_q))


def zero_current_values(mag: dict) -> dict:
    """psi_f = psi_d(0, 0) and the incremental inductances there
    (central differences over one grid step): what the injection sees at no
    load and what [electrical] states."""
    h_d = mag["i_d"][1] - mag["i_d"][0]
    h_q = mag["i_q"][1] - mag["i_q"][0]
    return {"psi_f": table_at(mag, "psi_d", 0.0, 0.0),
            "L_d": (table_at(mag, "psi_d", h_d, 0.0) - table_at(mag, "psi_d", -h_d, 0.0)) / (2 * h_d),
            "L_q": (table_at(mag, "psi_q", 0.0, h_q) - table_at(mag, "psi_q", 0.0, -h_q)) / (2 * h_q)}


def coverage_limit(mag: dict) -> float:
    """The largest current limit the map covers as check_coverage asks:
    i_q over +-i_max, i_d from -i_max up to +i_max / 2."""
    i_d, i_q = mag["i_d"], mag["i_q"]
    return float(min(-i_d[0], 2.0 * i_d[-1], -i_q[0], i_q[-1]))


def map_range(mag: dict) -> str:
    """'i_d -20..20 A, i_q -26..26 A': what a map covers, for messages."""
    return f"i_d {mag['i_d'][0]:g}..{mag['i_d'][-1]:g} A, i_q {mag['i_q'][0]:g}..{mag['i_q'][-1]:g} A"


def check_coverage(mag: dict, i_max: float, field: str, source) -> None:
    """The map must reach the current limit: i_q over +-i_max, i_d from
    -i_max up to +i_max / 2 (the polarity detection's positive d pulses are
    half of i_max by default). Outside, the plant would extrapolate."""
    i_d, i_q = mag["i_d"], mag["i_q"]
    tol = 1e-9 * i_max
    if i_q[0] > -i_max + tol or i_q[-1] < i_max - tol:
        raise ConfigError(f"{field}.i_q", f"{i_q[0]:g}..{i_q[-1]:g} A",
                          f"must cover +-i_max = +-{i_max:g} A (bench.i_max): the drive may ask for that current", source)
    if i_d[0] > -i_max + tol or i_d[-1] < 0.5 * i_max - tol:
        raise ConfigError(f"{field}.i_d", f"{i_d[0]:g}..{i_d[-1]:g} A",
                          f"must cover -i_max..i_max/2 = {-i_max:g}..{0.5 * i_max:g} A (bench.i_max; flux weakening "
                          "goes to -i_max, the polarity pulses to +i_max/2)", source)


def gross_disagreement(mag: dict, elec: dict) -> tuple[str, float, str] | None:
    """The first of psi_f, L_d, L_q whose [electrical] value and the map's at
    zero current lie more than GROSS_FACTOR apart (both > 0): its name,
    [electrical]'s value and what is allowed; None where none does."""
    z = zero_current_values(mag)
    for k, unit in (("psi_f", "Wb"), ("L_d", "H"), ("L_q", "H")):
        a, b = elec[k], z[k]
        if a > 0 and b > 0 and max(a / b, b / a) > GROSS_FACTOR * (1.0 + 1e-6):   # a factor of 2 itself is a warning
            unit_hint = (f" (a factor near 1000 is a unit: check {unit} against m{unit} in [electrical] and in the map's "
                         "header)") if max(a / b, b / a) > 300 else ""
            return k, a, (f"the flux map gives {b:.4g} {unit} at zero current, {b / a:.3g} x this: [electrical] and the map "
                          f"must describe one machine, within a factor {GROSS_FACTOR:g}{unit_hint}")
    return None


def consistency_warnings(mag: dict, elec: dict, pole_pairs: int, phases: int, name: str) -> list[str]:
    """Where [electrical] and the map disagree beyond the tolerances above:
    one line for all of them (empty when they agree)."""
    z = zero_current_values(mag)
    off = []
    if abs(z["psi_f"] - elec["psi_f"]) > PSI_F_TOL * abs(elec["psi_f"]) + 1e-12:
        off.append(f"psi_f {elec['psi_f']:.4g} Wb, map {z['psi_f']:.4g}")
    for k in ("L_d", "L_q"):
        if abs(z[k] - elec[k]) > L_TOL * elec[k]:
            off.append(f"{k} {elec[k]:.4g} H, map {z[k]:.4g} at zero current")
    if mag.get("torque") is not None:
        i_d, i_q = np.meshgrid(mag["i_d"], mag["i_q"], indexing="ij")
        T_map = np.asarray(mag["torque"])
        T_flux = 0.5 * phases * pole_pairs * (np.asarray(mag["psi_d"]) * i_q - np.asarray(mag["psi_q"]) * i_d)
        big = np.abs(T_map) > 0.1 * np.max(np.abs(T_map))
        if big.any():
            dev = float(np.median(np.abs(T_flux[big] - T_map[big]) / np.abs(T_map[big])))
            if dev > TORQUE_TOL:
                off.append(f"its torque column is {100 * dev:.0f} % from {phases}/2 p (psi_d i_q - psi_q i_d) with p = {pole_pairs}")
    if not off:
        return []
    return [f"{name}: [electrical] and the flux map disagree ({'; '.join(off)}; tolerances psi_f {100 * PSI_F_TOL:g} %, "
            f"L {100 * L_TOL:g} %, torque {100 * TORQUE_TOL:g} %): the plant and the controller's model follow the map; "
            "[electrical]'s values still enter some designed settings (the start's among them)"]
