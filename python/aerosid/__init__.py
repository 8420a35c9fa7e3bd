"""aerosid from Python: flight logs as one table, the model-gap analysis, the filter error method,
prediction, and the on-board recursive estimator.

Every function calls the Rust library the ``aerosid`` command is built on; its errors are raised as
:class:`AerosidError` (a :class:`ValueError`) with the command's messages (the file, line or field,
and the fix). Units are SI and angles radians throughout; column names carry their unit
(``pitch_rate_rad_s``, ``airspeed_mps``).

>>> import aerosid
>>> df = aerosid.read("flight.ulg")                      # a pandas DataFrame, index t_s
>>> report = aerosid.gaps("flight.asc", aircraft="hfb320.map")
>>> report["verdict"], report["top_cause"]
"""

from __future__ import annotations

import json
import os
import tempfile
from typing import Any, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _aerosid
from ._aerosid import AerosidError, Gtls

__all__ = [
    "AerosidError",
    "Gtls",
    "columns",
    "read",
    "gaps",
    "fem",
    "predict",
    "batch_one",
    "write_summary",
    "folder_name",
]

PathLike = Union[str, "os.PathLike[str]"]

#: The options of :func:`gaps` (the ``aerosid gaps`` flags), with their defaults.
GAPS_OPTIONS: Dict[str, Any] = {
    "air_data": "auto",
    "flow_angles": "auto",
    "corrections": True,
    "compatibility": True,
    "baseline": None,
    "max_rate_hz": 50.0,
    "low_rate_method": "output-error",
    "alpha": 0.01,
    "gain_alpha": 0.01,
}

#: The options of reading a .ulg or .bin log (``--from``, ``--to``, ``--whole-log``, ``--rate``,
#: ``--instance``).
READ_OPTIONS: Dict[str, Any] = {
    "from_s": None,
    "to_s": None,
    "whole_log": False,
    "rate_hz": None,
    "instances": (),
}


def columns() -> Dict[str, str]:
    """Every channel's column name and its SI unit, as :func:`read` names them."""
    return dict(_aerosid.columns())


def _path(p: Optional[PathLike]) -> Optional[str]:
    return None if p is None else os.fspath(p)


def _split(options: Mapping[str, Any], known: Mapping[str, Any], what: str) -> Dict[str, Any]:
    unknown = sorted(set(options) - set(known))
    if unknown:
        raise TypeError(
            f"{what}: unknown option(s) {', '.join(unknown)}; the options are {', '.join(sorted(known))}"
        )
    return {k: options.get(k, v) for k, v in known.items()}


def _read_kwargs(options: Dict[str, Any]) -> Dict[str, Any]:
    o = dict(options)
    o["instances"] = [str(i) for i in o["instances"]]
    return o


def read(data: PathLike, aircraft: Optional[PathLike] = None, **options: Any):
    """Reads a flight into one table on a uniform time base: every channel in SI units.

    ``data`` is any file ``aerosid gaps --data`` reads (the project's CSV, a whitespace ASCII file,
    a ``.mat`` file, a PX4 ``.ulg``, an ArduPilot ``.bin``); ``aircraft`` is what ``--with`` takes
    (a column map ``.map`` or an aircraft file ``.aircraft``; optional for ``.ulg`` and ``.bin``).
    ``options``: ``from_s``, ``to_s``, ``whole_log``, ``rate_hz``, ``instances`` (``["TOPIC=N"]``),
    as the command's flags.

    Returns a pandas DataFrame indexed by ``t_s`` (its ``attrs`` hold the source, the aircraft,
    the format, the window, the warnings and each column's unit), or, without pandas, a dict of
    numpy arrays with ``t_s`` among them.
    """
    o = _read_kwargs(_split(options, READ_OPTIONS, "read"))
    source, t_s, cols, meta = _aerosid.read(os.fspath(data), _path(aircraft), **o)
    try:
        import pandas as pd
    except ImportError:
        out = {"t_s": t_s}
        out.update(cols)
        return out
    df = pd.DataFrame(dict(cols), index=pd.Index(t_s, name="t_s"))
    df.attrs.update(meta)
    return df


def _frame_parts(frame: Any) -> Tuple[np.ndarray, List[Tuple[str, np.ndarray]]]:
    """The time base and the channels of a DataFrame (index ``t_s`` or a ``t_s`` column) or of a
    dict of arrays."""
    if isinstance(frame, Mapping):
        if "t_s" not in frame:
            raise ValueError("a dict of channels needs its time base under `t_s` (seconds)")
        t_s = np.asarray(frame["t_s"], dtype=np.float64)
        items = [(str(k), v) for k, v in frame.items() if k != "t_s"]
    else:
        if "t_s" in frame.columns:
            t_s = frame["t_s"].to_numpy(dtype=np.float64)
            items = [(str(c), frame[c]) for c in frame.columns if c != "t_s"]
        else:
            if frame.index.name != "t_s":
                raise ValueError(
                    "a DataFrame needs its time base, in seconds, as the index named `t_s` "
                    "(as aerosid.read returns it) or as a column `t_s`"
                )
            t_s = frame.index.to_numpy(dtype=np.float64)
            items = [(str(c), frame[c]) for c in frame.columns]
    chans = [(k, np.ascontiguousarray(np.asarray(v, dtype=np.float64))) for k, v in items]
    return np.ascontiguousarray(t_s), chans


def _is_frame(data: Any) -> bool:
    return isinstance(data, Mapping) or (hasattr(data, "columns") and hasattr(data, "index"))


def gaps(
    data: Any,
    aircraft: Optional[PathLike] = None,
    *,
    out: Optional[PathLike] = None,
    **options: Any,
) -> Dict[str, Any]:
    """The model-gap analysis (``aerosid gaps``): what the identified model gets wrong and why.

    ``data``: a flight file (with ``aircraft`` as ``--with`` takes it); a list of the files of one
    flight test, whose manoeuvres are pooled into one analysis as the command's repeated
    ``--data`` pools them (every file read with the same ``aircraft``; each one's manoeuvres held
    out whole in the cross-validation; docs/model-gaps.md, "Pooled manoeuvres"); or a DataFrame /
    dict of arrays in the layout :func:`read` returns (then ``aircraft`` is an ``.aircraft`` file,
    or None for no verdict).

    ``options``: ``air_data`` (auto, measured, reconstructed, fused), ``flow_angles`` (auto, vanes,
    estimated, none), ``corrections`` (False keeps the named sensor errors), ``compatibility``,
    ``baseline`` (e.g. ``"CL=1,alpha,dV"``), ``max_rate_hz`` (None: as logged),
    ``low_rate_method`` (output-error, filter-error, test: below 20 Hz), ``alpha``, ``gain_alpha``; for files ``segments`` (``[(from_s, to_s), ...]`` seconds from each file's
    first sample, each its own manoeuvre: ``--segment``), and for ``.ulg`` / ``.bin`` files the
    options of :func:`read`.
    ``out``: a folder for report.json, report.txt and the figures (none written without it).

    Returns the report.json content (schema ``aerosid-gaps/3``, docs/model-gaps.md) as a dict.
    """
    if isinstance(data, (list, tuple)):
        if any(_is_frame(d) for d in data):
            raise ValueError(
                "a list given to gaps holds the flight files to pool; a DataFrame or dict of "
                "arrays is analysed on its own (aerosid.gaps(frame))"
            )
        if not data:
            raise ValueError("no flight given: data is an empty list")
    if _is_frame(data):
        g = _split(options, GAPS_OPTIONS, "gaps")
        t_s, chans = _frame_parts(data)
        source = "DataFrame"
        attrs = getattr(data, "attrs", None)
        if isinstance(attrs, Mapping) and attrs.get("source"):
            source = f"DataFrame of {attrs['source']}"
        text = _aerosid.gaps_frame(source, t_s, chans, _path(aircraft), _path(out), **g)
    else:
        g = _split(options, {**GAPS_OPTIONS, **READ_OPTIONS, "segments": None}, "gaps")
        r = _read_kwargs({k: g.pop(k) for k in READ_OPTIONS})
        segments = _segments(g.pop("segments"))
        text = _aerosid.gaps_file(_paths(data), _path(aircraft), _path(out), segments, **r, **g)
    return json.loads(text)


def _segments(s: Optional[Iterable[Sequence[float]]]) -> List[Tuple[float, float]]:
    return [(float(a), float(b)) for a, b in (s or [])]


def _json_of(files: Sequence[str], name: str) -> Dict[str, Any]:
    for f in files:
        if os.path.basename(f) == name:
            with open(f, encoding="utf-8") as fh:
                return json.load(fh)
    raise AerosidError(f"{name} was not written")


def _paths(p: Union[None, PathLike, Sequence[PathLike]]) -> List[str]:
    if p is None:
        return []
    if isinstance(p, (str, os.PathLike)):
        return [os.fspath(p)]
    return [os.fspath(x) for x in p]


def fem(
    model: PathLike,
    data: Union[None, PathLike, Sequence[PathLike]] = None,
    *,
    aircraft: Optional[PathLike] = None,
    segments: Optional[Iterable[Sequence[float]]] = None,
    validate: Union[None, PathLike, Sequence[PathLike]] = None,
    validate_segments: Optional[Iterable[Sequence[float]]] = None,
    fix: Optional[Mapping[str, float]] = None,
    out: Optional[PathLike] = None,
) -> Dict[str, Any]:
    """The filter error / output error method on a user model file (``aerosid fem``).

    ``model``: the TOML model file; ``data``: one or more data files (default the model's
    ``[data] file``); ``aircraft``: the column map or aircraft file of the data files, as the
    command's ``--with`` (a model that names measured channels reads any file ``gaps`` reads);
    ``segments``: ``[(from_s, to_s), ...]`` of each data file; ``validate``,
    ``validate_segments``: validation data; ``fix``: ``{name: value}`` parameters held fixed;
    ``out``: the folder for identification.json and the figures (a temporary one when None).

    Returns the identification.json content as a dict, with the text report under ``"text"``.
    """
    fixes = [(str(k), float(v)) for k, v in (fix or {}).items()]
    with _out_dir(out) as d:
        text, files = _aerosid.fem(
            os.fspath(model),
            d,
            data=_paths(data),
            with_=_path(aircraft),
            segments=_segments(segments),
            validate=_paths(validate),
            validate_segments=_segments(validate_segments),
            fix=fixes,
        )
        result = _json_of(files, "identification.json")
    result["text"] = text
    return result


def predict(
    saved: PathLike,
    data: Union[None, PathLike, Sequence[PathLike]] = None,
    aircraft: Optional[PathLike] = None,
    *,
    segments: Optional[Iterable[Sequence[float]]] = None,
    out: Optional[PathLike] = None,
) -> Dict[str, Any]:
    """Applies a saved model to other data (``aerosid predict``).

    ``saved``: the identification.json of :func:`fem`, or the report.json of :func:`gaps` (then
    ``data`` is one flight); ``aircraft`` is the data's ``--with`` either way. ``segments`` are for
    fem models.
    ``out``: the folder for prediction.json and the figures (a temporary one when None).

    Returns the prediction.json content as a dict, with the text report under ``"text"``.
    """
    with _out_dir(out) as d:
        text, files = _aerosid.predict(
            os.fspath(saved), d, data=_paths(data), with_=_path(aircraft), segments=_segments(segments)
        )
        result = _json_of(files, "prediction.json")
    result["text"] = text
    return result


class _out_dir:
    """The folder given, or a temporary one removed afterwards."""

    def __init__(self, out: Optional[PathLike]):
        self._out = out
        self._tmp: Optional[tempfile.TemporaryDirectory] = None

    def __enter__(self) -> str:
        if self._out is not None:
            return os.fspath(self._out)
        self._tmp = tempfile.TemporaryDirectory(prefix="aerosid-")
        return self._tmp.name

    def __exit__(self, *exc: Any) -> None:
        if self._tmp is not None:
            self._tmp.cleanup()


def batch_one(
    file: PathLike, out: PathLike, aircraft: Optional[PathLike] = None, force: bool = False
) -> Dict[str, Any]:
    """One log of ``aerosid batch``: analysed into ``out/<folder_name(file)>`` (or read back when
    its report.json exists and not ``force``); its summary row as a dict (``file``, ``folder``,
    ``status``, ``top_cause``, ``reason``, ``seconds``, ``resumed``). Never raises for a bad log:
    its row has status ``error`` and the message."""
    return _aerosid.batch_one(os.fspath(file), os.fspath(out), with_=_path(aircraft), force=force)


def write_summary(out: PathLike, rows: Sequence[Mapping[str, Any]]) -> None:
    """Writes summary.csv and summary.jsonl of rows of :func:`batch_one` to ``out``, as
    ``aerosid batch`` writes them."""
    _aerosid.write_summary(os.fspath(out), [dict(r) for r in rows])


def folder_name(file: PathLike) -> str:
    """The folder of a log in a batch: its file name and a hash of its canonical path."""
    return _aerosid.folder_name(os.fspath(file))
