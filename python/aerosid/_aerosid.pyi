"""Type stubs of the Rust extension (aerosid._aerosid); the documented API is aerosid/__init__.py."""

from os import PathLike
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

_Path = Union[str, PathLike[str]]
_F64 = npt.NDArray[np.float64]

class AerosidError(ValueError):
    """An error of aerosid, with the command line's message."""

class Gtls:
    """The recursive PCA-GTLS estimator (Algorithm 1; aerosid_core::Gtls) for float64.

    ``n`` parameters (1-6), the first ``n_exact`` (0 or 1) on exact regressors (e.g. a bias
    column of ones); ``w_t`` the error covariance of the noisy block ``[x_noisy, z]`` (eq. 9),
    ``(n - n_exact + 1)`` square, default the identity; ``weights`` the diagonal of W (eq. 23),
    default ones; ``snr`` the excitation threshold of eq. 21; ``forgetting`` a constant λ in
    (0, 1]; ``max_abs_input`` the largest accepted magnitude of any input.
    """

    def __init__(
        self,
        n: int,
        n_exact: int = 0,
        w_t: Optional[_F64] = None,
        weights: Optional[_F64] = None,
        snr: float = 1.0,
        forgetting: float = 1.0,
        max_abs_input: float = 1e6,
    ) -> None: ...
    def update(self, row: _F64) -> bool:
        """One sample ``[x_1 ... x_n, z]``; False (state unchanged) when refused."""
    def update_many(self, rows: _F64) -> int:
        """Rows of an ``(m, n + 1)`` array; the number accepted."""
    @property
    def theta(self) -> _F64:
        """The estimate θ̂."""
    @property
    def sigma(self) -> _F64:
        """Standard errors of θ̂ (eq. 17); NaN while not every parameter is excited."""
    @property
    def covariance(self) -> Optional[_F64]:
        """Covariance of θ̂ (eq. 17), n×n; None while not every parameter is excited."""
    @property
    def excited(self) -> int:
        """Excited directions k of the noisy regressors (eq. 21); n - n_exact when all are."""
    @property
    def forgetting(self) -> float:
        """λ applied to the next sample."""
    @property
    def effective_samples(self) -> float:
        """Σ Π λ."""
    @property
    def rejected(self) -> int:
        """Samples refused."""
    @property
    def health(self) -> Dict[str, int]:
        """updates, reorthonormalisations, nongeneric, secular_not_converged."""

def columns() -> List[Tuple[str, str]]: ...
def read(
    data: _Path,
    with_: Optional[_Path] = None,
    from_s: Optional[float] = None,
    to_s: Optional[float] = None,
    whole_log: bool = False,
    rate_hz: Optional[float] = None,
    instances: Sequence[str] = ...,
) -> Tuple[str, _F64, List[Tuple[str, _F64]], Dict[str, Any]]: ...
def gaps_file(
    data: Sequence[_Path],
    with_: Optional[_Path] = None,
    out: Optional[_Path] = None,
    segments: Sequence[Tuple[float, float]] = ...,
    from_s: Optional[float] = None,
    to_s: Optional[float] = None,
    whole_log: bool = False,
    rate_hz: Optional[float] = None,
    instances: Sequence[str] = ...,
    air_data: str = "auto",
    flow_angles: str = "auto",
    corrections: bool = True,
    compatibility: bool = True,
    baseline: Optional[str] = None,
    max_rate_hz: Optional[float] = 50.0,
    low_rate_method: str = "output-error",
    alpha: float = 0.01,
    gain_alpha: float = 0.01,
) -> str: ...
def gaps_frame(
    source: str,
    t_s: _F64,
    channels: Sequence[Tuple[str, _F64]],
    aircraft: Optional[_Path] = None,
    out: Optional[_Path] = None,
    air_data: str = "auto",
    flow_angles: str = "auto",
    corrections: bool = True,
    compatibility: bool = True,
    baseline: Optional[str] = None,
    max_rate_hz: Optional[float] = 50.0,
    low_rate_method: str = "output-error",
    alpha: float = 0.01,
    gain_alpha: float = 0.01,
) -> str: ...
def fem(
    model: _Path,
    out: _Path,
    data: Sequence[_Path] = ...,
    with_: Optional[_Path] = ...,
    segments: Sequence[Tuple[float, float]] = ...,
    validate: Sequence[_Path] = ...,
    validate_segments: Sequence[Tuple[float, float]] = ...,
    fix: Sequence[Tuple[str, float]] = ...,
) -> Tuple[str, List[str]]: ...
def predict(
    saved: _Path,
    out: _Path,
    data: Sequence[_Path] = ...,
    with_: Optional[_Path] = None,
    segments: Sequence[Tuple[float, float]] = ...,
) -> Tuple[str, List[str]]: ...
def batch_one(file: _Path, out: _Path, with_: Optional[_Path] = None, force: bool = False) -> Dict[str, Any]: ...
def write_summary(out: _Path, rows: Sequence[Dict[str, Any]]) -> None: ...
def folder_name(file: _Path) -> str: ...
