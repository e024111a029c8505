"""Sensor profiles: what a real skin's read-out does, measured, in one file a scene can name.

A profile is a TOML file (``vtcore calibrate`` writes one; ``vtcore/contact/profiles/`` ships
the CySkin profile fitted on the shared recordings, ``load_profile("cyskin")``):

* ``[profile]`` name, description, source (the recordings), version.
* ``[noise]`` the read noise of an idle taxel with the recorder's clipping at 0 accounted for
  (a censored-normal fit per taxel): ``sigma_counts`` (median over taxels), its IQR and the 95 %
  interval of the median, the per-taxel offsets, drift and lag-1 correlation.
* ``[detection]`` ``k``: a taxel is active when it reads more than k noise deviations.
* ``[response]`` (optional, from the footprint fit): the layer and transfer curve that reproduce
  the recorded footprints, each value with its interval and whether the data identify it.
* ``[taxels]`` (optional): per-taxel ``uid``, ``sigma_counts``, ``offset_counts``, ``drift_counts_per_s``
  for the recorded skin; a layout with other UIDs uses the medians.

Every field is checked on load (type, range, array lengths); a missing or out-of-range value
raises an :class:`vtcore.errors.InputError` naming the file and key.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import FormatError, InputError
from ..inputs import Spec, clean, read_text, validate
from .objects import DEFAULTS as OBJECT_KINDS

#: the folder of the profiles shipped with vtcore
PROFILES_DIR = Path(__file__).with_name("profiles")
MAX_COUNTS = 65535.0


@dataclass(frozen=True)
class Response:
    """The fitted soft layer and transfer curve (``[response]``).

    thickness : m, layer thickness, with ``thickness_ci`` (lo, hi) m. young_modulus : Pa, an
    assumption (force is not recorded: only force / modulus is identified). counts_per_pa : the
    transfer's slope at 0 for that modulus. p_half : Pa or None (linear), half-ceiling pressure.
    base : "bonded" or "frictionless". indenter : dict (the probe the fit used: kind, radius,
    length, m; conform; wrap, 0-1). fields : the report keys of the section as read, each checked (intervals,
    notes, the fit's quality), kept for reports.
    """

    thickness: float
    thickness_ci: tuple
    young_modulus: float
    poisson: float
    counts_per_pa: float
    p_half: float | None
    base: str
    material: str
    indenter: dict
    fields: dict = field(default_factory=dict)

    def press_indenter(self) -> dict:
        """The fitted probe as a matched press takes it: kind, its dimensions (m) and its wrap
        (``conform`` is the press's own switch)."""
        return {k: v for k, v in self.indenter.items() if k in ("kind", "radius", "length", "wrap")}


@dataclass(frozen=True)
class SensorProfile:
    """A measured sensor profile (see the module docstring for the file).

    noise_sigma : counts, median per-taxel read-noise standard deviation (clipping accounted for).
    noise_sigma_iqr, noise_sigma_ci95 : (2,) counts. detection_k : noise deviations for "active";
    min_active, radius (m): a frame is a contact frame with at least min_active active taxels within
    radius of its strongest one.
    clip_counts : the level recordings are clipped at. offset_counts, drift_counts_per_s : medians.
    taxel_ids, taxel_sigma, taxel_offset, taxel_drift : (M,) per recorded taxel, or None.
    response : :class:`Response` or None. path : the file read. raw : the file's tables as read.
    """

    name: str
    noise_sigma: float
    detection_k: float
    noise_sigma_iqr: tuple = (math.nan, math.nan)
    noise_sigma_ci95: tuple = (math.nan, math.nan)
    clip_counts: float = 0.0
    offset_counts: float = 0.0
    drift_counts_per_s: float = 0.0
    lag1_correlation: float = 0.0
    min_active: int = 3
    radius: float = 0.03
    source: str = ""
    description: str = ""
    taxel_ids: np.ndarray | None = None
    taxel_sigma: np.ndarray | None = None
    taxel_offset: np.ndarray | None = None
    taxel_drift: np.ndarray | None = None
    response: Response | None = None
    path: str = ""
    raw: dict = field(default_factory=dict, repr=False)

    def per_taxel(self, taxel_ids, what: str = "sigma") -> np.ndarray:
        """(N,) the per-taxel ``what`` ("sigma" counts, "offset" counts, "drift" counts/s) for a
        layout's ``taxel_ids`` (N,): the measured value where the UID was measured and identified,
        else the profile's median."""
        ids = np.asarray(taxel_ids, np.int64).reshape(-1)
        default = {"sigma": self.noise_sigma, "offset": 0.0, "drift": 0.0}[what]
        out = np.full(len(ids), float(default))
        table = {"sigma": self.taxel_sigma, "offset": self.taxel_offset, "drift": self.taxel_drift}[what]
        if self.taxel_ids is None or table is None or len(ids) == 0:
            return out
        order = np.argsort(self.taxel_ids, kind="stable")
        sid = self.taxel_ids[order]
        pos = np.clip(np.searchsorted(sid, ids), 0, len(sid) - 1)
        hit = sid[pos] == ids
        vals = table[order][pos]
        use = hit & np.isfinite(vals)
        out[use] = vals[use]
        return out

    def threshold(self, taxel_ids=None, k: float | None = None):
        """Counts above which a taxel is active: k x its sigma ((N,) for ``taxel_ids``, else a float)."""
        kk = self.detection_k if k is None else float(k)
        if taxel_ids is None:
            return kk * self.noise_sigma
        return kk * self.per_taxel(taxel_ids, "sigma")


def _positive_pair(v):
    if len(v) != 2 or not (v[0] <= v[1]):
        return "must be [low, high] with low <= high"
    return None


_PROFILE = {"name": Spec("str"), "description": Spec("str", required=False, default=""),
            "source": Spec("str", required=False, default=""), "version": Spec("int", required=False, default=1,
                                                                                 lo=1, hi=1)}
_NOISE = {
    "sigma_counts": Spec("float", lo=1e-6, hi=MAX_COUNTS),
    "sigma_counts_iqr": Spec("floats", required=False, default=None, shape=(2,), lo=0, hi=MAX_COUNTS,
                             check=_positive_pair),
    "sigma_counts_ci95": Spec("floats", required=False, default=None, shape=(2,), lo=0, hi=MAX_COUNTS,
                              check=_positive_pair),
    "clip_counts": Spec("float", required=False, default=0.0, lo=0.0, hi=MAX_COUNTS),
    "offset_counts": Spec("float", required=False, default=0.0, lo=-MAX_COUNTS, hi=MAX_COUNTS),
    "drift_counts_per_s": Spec("float", required=False, default=0.0, lo=-1e5, hi=1e5),
    "lag1_correlation": Spec("float", required=False, default=0.0, lo=-1.0, hi=1.0),
    # what the fit saw (reports only)
    "naive_std_counts": Spec("float", required=False, lo=0.0, hi=MAX_COUNTS),
    "taxels_identified": Spec("int", required=False, lo=0), "taxels_recorded": Spec("int", required=False, lo=0),
    "idle_frames": Spec("int", required=False, lo=0), "contact_frames": Spec("int", required=False, lo=0),
}
_DETECTION = {"k": Spec("float", lo=0.1, hi=100.0), "min_active": Spec("int", required=False, default=3, lo=1, hi=1000),
              "radius_m": Spec("float", required=False, default=0.03, lo=1e-4, hi=1.0)}
_RESPONSE = {
    "thickness_m": Spec("float", lo=1e-4, hi=0.05),
    "thickness_ci_m": Spec("floats", required=False, default=None, shape=(2,), lo=0.0, hi=0.05, check=_positive_pair),
    "young_modulus_pa": Spec("float", lo=1e2, hi=1e10),
    "poisson": Spec("float", required=False, default=0.49, lo=0.0, hi=0.4999),
    "counts_per_pa": Spec("float", lo=1e-9, hi=1e6),
    "p_half_pa": Spec("float", required=False, default=None, lo=1e-3, hi=1e9),
    "base": Spec("str", required=False, default="bonded", choices=("bonded", "frictionless")),
    "material": Spec("str", required=False, default="ecoflex_00_20"),
    "indenter": Spec("record", required=False, default={}, fields={
        "kind": Spec("str", choices=tuple(OBJECT_KINDS)),
        "radius": Spec("float", required=False, lo=1e-3, hi=0.1),
        "length": Spec("float", required=False, lo=1e-3, hi=0.5),
        "conform": Spec("bool", required=False),
        "wrap": Spec("float", required=False, lo=0.0, hi=1.0)}),
}
#: what the footprint fit saw and how well it fitted (``vtcore calibrate`` writes them; reports read
#: them, ``vtcore validate`` the ``held_out`` recordings): typed like every other key, kept in ``fields``
_RESPONSE_REPORT = {
    "counts_per_pa_ci": Spec("floats", required=False, shape=(2,), lo=0.0, hi=1e6, check=_positive_pair),
    "radius_ci_m": Spec("floats", required=False, shape=(2,), lo=0.0, hi=1.0, check=_positive_pair),
    "length_ci_m": Spec("floats", required=False, shape=(2,), lo=0.0, hi=1.0, check=_positive_pair),
    "wrap_ci": Spec("floats", required=False, shape=(2,), lo=0.0, hi=1.0, check=_positive_pair),
    "p_half_ci_pa": Spec("floats", required=False, shape=(2,), lo=0.0, hi=1e13, check=_positive_pair),
    "force_over_modulus_m2_median": Spec("float", required=False, lo=0.0, hi=1.0),
    "force_over_modulus_m2_iqr": Spec("floats", required=False, shape=(2,), lo=0.0, hi=1.0, check=_positive_pair),
    "implied_force_n_median": Spec("float", required=False, lo=0.0, hi=1e6),
    "max_compression": Spec("float", required=False, lo=0.0, hi=1.0),
    "score_per_term": Spec("float", required=False, lo=0.0, hi=1e12),
    "frames": Spec("int", required=False, lo=0, hi=2**31),
    "fitted": Spec("strs", required=False), "held_out": Spec("strs", required=False),
    "identified": Spec("strs", required=False), "not_identified": Spec("strs", required=False),
}
#: the tables of a profile file and whether each is required
TABLES = {"profile": True, "noise": True, "detection": True, "response": False, "taxels": False}


def _taxels(tab, path) -> dict:
    """The ``[taxels]`` arrays, equal lengths, UIDs as integers, values finite or NaN-free."""
    spec = {"uid": Spec("ints", dtype=np.int64, lo=0, hi=2**32 - 1, shape=(None,)),
            "sigma_counts": Spec("floats", required=False, default=None),
            "offset_counts": Spec("floats", required=False, default=None),
            "drift_counts_per_s": Spec("floats", required=False, default=None)}
    for k in tab:
        if k not in spec:
            raise InputError(f"unknown key; valid keys: {', '.join(spec)}", file=path, key=f"taxels.{clean(k, 40)}")
    # NaN (a taxel whose value is not identifiable) is written as the string "nan" in TOML: nan
    raw = {k: ([math.nan if (isinstance(x, float) and math.isnan(x)) else x for x in v]
               if isinstance(v, list) else v) for k, v in tab.items()}
    out = {}
    for k, s in spec.items():
        if k not in raw:
            if s.required:
                raise InputError("is required", file=path, key=f"taxels.{k}")
            out[k] = None
            continue
        if s.kind == "ints":
            out[k] = validate({k: raw[k]}, {k: s}, file=path, prefix="taxels")[k]
        else:
            try:
                a = np.asarray(raw[k], dtype=np.float64)
            except (TypeError, ValueError):
                raise InputError("must be a list of numbers (nan where not identified)", file=path,
                                 key=f"taxels.{k}") from None
            if a.ndim != 1 or np.isinf(a).any():
                raise InputError("must be a flat list of finite numbers or nan", file=path, key=f"taxels.{k}")
            if k == "sigma_counts" and (np.nanmin(a, initial=1.0) <= 0 or np.nanmax(a, initial=0) > MAX_COUNTS):
                raise InputError(f"values must be in (0, {MAX_COUNTS:g}] counts", file=path, key=f"taxels.{k}")
            out[k] = a
    n = len(out["uid"])
    for k in ("sigma_counts", "offset_counts", "drift_counts_per_s"):
        if out[k] is not None and len(out[k]) != n:
            raise InputError(f"has {len(out[k])} values but taxels.uid has {n}", file=path, key=f"taxels.{k}")
    return out


def parse_profile(doc: dict, path="<profile>") -> SensorProfile:
    """A :class:`SensorProfile` from a decoded TOML document (checked; errors name ``path`` and key)."""
    if not isinstance(doc, dict):
        raise FormatError("a profile must be a TOML document", file=path)
    for k in doc:
        if k not in TABLES:
            raise InputError(f"unknown table; valid: {', '.join(sorted(TABLES))}", file=path, key=clean(k, 40))
    for k, required in TABLES.items():
        if required and k not in doc:
            raise InputError("is required (a profile needs [profile], [noise] and [detection])", file=path, key=k)
        if k in doc and not isinstance(doc[k], dict):
            raise InputError(f"must be a table ([{k}] with its keys), got {type(doc[k]).__name__}", file=path, key=k)
    pr = validate(doc["profile"], _PROFILE, file=path, prefix="profile", extra=False)
    nz = validate(doc["noise"], _NOISE, file=path, prefix="noise", extra=False)
    dt = validate(doc["detection"], _DETECTION, file=path, prefix="detection", extra=False)
    resp = None
    if "response" in doc:
        r = validate(doc["response"], {**_RESPONSE, **_RESPONSE_REPORT}, file=path, prefix="response", extra=False)
        ci = r["thickness_ci_m"]
        if ci is not None and not (ci[0] <= r["thickness_m"] <= ci[1]):
            raise InputError(f"thickness_m {r['thickness_m']:g} lies outside its interval {list(ci)}", file=path,
                             key="response.thickness_m")
        extra = {k: doc["response"][k] for k in _RESPONSE_REPORT if r[k] is not None}  # checked: as read
        resp = Response(thickness=r["thickness_m"], thickness_ci=tuple(ci) if ci is not None else (math.nan,) * 2,
                        young_modulus=r["young_modulus_pa"], poisson=r["poisson"], counts_per_pa=r["counts_per_pa"],
                        p_half=r["p_half_pa"], base=r["base"], material=r["material"],
                        indenter={k: v for k, v in r["indenter"].items() if v is not None}, fields=extra)
    tx = _taxels(doc["taxels"], path) if "taxels" in doc else None

    def pair(v):
        return tuple(float(x) for x in v) if v is not None else (math.nan, math.nan)

    return SensorProfile(
        name=pr["name"], description=pr["description"], source=pr["source"], noise_sigma=nz["sigma_counts"],
        noise_sigma_iqr=pair(nz["sigma_counts_iqr"]), noise_sigma_ci95=pair(nz["sigma_counts_ci95"]),
        clip_counts=nz["clip_counts"], offset_counts=nz["offset_counts"], drift_counts_per_s=nz["drift_counts_per_s"],
        lag1_correlation=nz["lag1_correlation"], detection_k=dt["k"], min_active=dt["min_active"],
        radius=dt["radius_m"],
        taxel_ids=None if tx is None else tx["uid"], taxel_sigma=None if tx is None else tx["sigma_counts"],
        taxel_offset=None if tx is None else tx["offset_counts"],
        taxel_drift=None if tx is None else tx["drift_counts_per_s"], response=resp, path=str(path), raw=doc)


def profile_path(name_or_path) -> Path:
    """The file of a shipped profile name (``"cyskin"``) or of a path to a ``.toml`` file."""
    s = str(name_or_path)
    p = Path(s)
    if p.suffix.lower() != ".toml" and "/" not in s and "\\" not in s:
        shipped = PROFILES_DIR / f"{s}.toml"
        if not shipped.is_file():
            names = sorted(q.stem for q in PROFILES_DIR.glob("*.toml"))
            raise InputError(f"no shipped sensor profile {clean(s, 60)!r}; shipped: {', '.join(names)}, "
                             "or give the path of a .toml profile file", key="profile")
        return shipped
    return p


def load_profile(name_or_path) -> SensorProfile:
    """Load a sensor profile: a shipped name (``"cyskin"``) or the path of a profile TOML file."""
    path = profile_path(name_or_path)
    text = read_text(path, "sensor profile")
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        import re

        m = re.search(r"at line (\d+)", str(exc))
        raise FormatError(f"not valid TOML: {clean(exc, 200)}", file=path,
                          line=int(m.group(1)) if m else None) from None
    return parse_profile(doc, path)


# ------------------------------------------------------------------------------ writing
def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        f = float(v)
        return "nan" if math.isnan(f) else ("inf" if f > 0 else "-inf") if math.isinf(f) else repr(f)
    if isinstance(v, str):
        import json

        return json.dumps(v, ensure_ascii=False).replace("\x7f", "\\u007f")
    if isinstance(v, np.ndarray):
        v = v.tolist()
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + " }"
    if v is None:
        raise InputError("a profile value cannot be None (leave the key out)", key="profile")
    raise InputError(f"cannot write a {type(v).__name__} into a profile", key="profile")


def profile_toml(doc: dict, comments: dict | None = None) -> str:
    """TOML text of a profile document ``{table: {key: value}}`` (None values left out).

    comments : ``{"table": "text", "table.key": "text"}`` written as ``#`` lines above them, so a
    reader of the file sees what each number is and where it came from.
    """
    comments = comments or {}
    out = []
    for table, body in doc.items():
        if comments.get(table):
            out += [f"# {line}" for line in comments[table].splitlines()]
        out.append(f"[{table}]")
        for k, v in body.items():
            if v is None:
                continue
            c = comments.get(f"{table}.{k}")
            if c:
                out += [f"# {line}" for line in c.splitlines()]
            out.append(f"{k} = {_toml_value(v)}")
        out.append("")
    return "\n".join(out)


def save_profile(path, doc: dict, comments: dict | None = None) -> SensorProfile:
    """Write a profile document as TOML (atomically), after checking it parses as a profile."""
    from .._io import atomic_write

    text = profile_toml(doc, comments)
    prof = parse_profile(tomllib.loads(text), path)     # never write a file load_profile refuses
    with atomic_write(path, "w", encoding="utf-8") as fh:
        fh.write(text)
    return prof
