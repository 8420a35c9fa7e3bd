"""Type stubs of the aerosid package (the docstrings are in __init__.py)."""

from os import PathLike
from typing import Any, Dict, Iterable, Mapping, Optional, Sequence, Union

from ._aerosid import AerosidError as AerosidError
from ._aerosid import Gtls as Gtls

_Path = Union[str, PathLike[str]]
_Paths = Union[None, _Path, Sequence[_Path]]

GAPS_OPTIONS: Dict[str, Any]
READ_OPTIONS: Dict[str, Any]

def columns() -> Dict[str, str]: ...
def read(data: _Path, aircraft: Optional[_Path] = None, **options: Any) -> Any: ...
def gaps(data: Any, aircraft: Optional[_Path] = None, *, out: Optional[_Path] = None, **options: Any) -> Dict[str, Any]: ...
def fem(
    model: _Path,
    data: _Paths = None,
    *,
    aircraft: Optional[_Path] = None,
    segments: Optional[Iterable[Sequence[float]]] = None,
    validate: _Paths = None,
    validate_segments: Optional[Iterable[Sequence[float]]] = None,
    fix: Optional[Mapping[str, float]] = None,
    out: Optional[_Path] = None,
) -> Dict[str, Any]: ...
def predict(
    saved: _Path,
    data: _Paths = None,
    aircraft: Optional[_Path] = None,
    *,
    segments: Optional[Iterable[Sequence[float]]] = None,
    out: Optional[_Path] = None,
) -> Dict[str, Any]: ...
def batch_one(file: _Path, out: _Path, aircraft: Optional[_Path] = None, force: bool = False) -> Dict[str, Any]: ...
def write_summary(out: _Path, rows: Sequence[Mapping[str, Any]]) -> None: ...
def folder_name(file: _Path) -> str: ...
