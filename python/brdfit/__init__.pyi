"""Type stubs of brdfit: fit reflection models to measured reflectance, numpy in and out."""

import os
from typing import Any, Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

PathLike = Union[str, "os.PathLike[str]"]
Data = Union["Dataset", PathLike, Tuple[npt.ArrayLike, npt.ArrayLike]]

__version__: str

class BrdfitError(ValueError):
    """An error brdfit reports, with the command line's message (file, line, fix)."""

class Dataset:
    """Reflectance samples: angles in radians, one column of values per channel."""

    def __len__(self) -> int: ...
    @property
    def theta_i(self) -> npt.NDArray[np.float64]: ...
    @property
    def phi_i(self) -> npt.NDArray[np.float64]: ...
    @property
    def theta_o(self) -> npt.NDArray[np.float64]: ...
    @property
    def phi_o(self) -> npt.NDArray[np.float64]: ...
    @property
    def directions(self) -> npt.NDArray[np.float64]:
        """(N, 4): θi, φi, θo, φo in radians."""
    @property
    def values(self) -> npt.NDArray[np.float64]:
        """(N, C) in the data's quantity; NaN marks a missing value."""
    @property
    def channels(self) -> List[str]: ...
    @property
    def wavelengths(self) -> List[Optional[float]]: ...
    @property
    def quantity(self) -> str:
        """brdf, brdf_cos or rfactor."""
    @property
    def weights(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def source(self) -> str: ...
    @property
    def format(self) -> str: ...
    @property
    def material(self) -> Optional[str]: ...
    @property
    def comments(self) -> List[str]: ...
    @property
    def warnings(self) -> List[str]: ...
    @property
    def negatives(self) -> int: ...
    def select(self, channel: str) -> "Dataset": ...
    def representative(self) -> "Dataset": ...
    def summary(self) -> str: ...

class FitResult:
    """One fit: parameters, standard errors, correlations, confidence intervals, checks, BIC."""

    @property
    def model(self) -> str: ...
    @property
    def distribution(self) -> str: ...
    @property
    def label(self) -> str: ...
    @property
    def channel(self) -> str: ...
    @property
    def params(self) -> Dict[str, float]: ...
    @property
    def stderr(self) -> Dict[str, float]: ...
    @property
    def correlation(self) -> npt.NDArray[np.float64]: ...
    @property
    def intervals(self) -> Dict[str, Tuple[float, float]]: ...
    @property
    def interval_level(self) -> float: ...
    @property
    def ranges(self) -> Dict[str, Tuple[float, float]]: ...
    @property
    def flags(self) -> List[str]: ...
    @property
    def usable(self) -> bool: ...
    @property
    def unusable(self) -> List[str]: ...
    @property
    def warnings(self) -> List[str]: ...
    @property
    def bic(self) -> float: ...
    @property
    def aic(self) -> float: ...
    @property
    def cost(self) -> float: ...
    @property
    def rmse(self) -> float: ...
    @property
    def samples_used(self) -> int: ...
    @property
    def n_free(self) -> int: ...
    @property
    def seconds(self) -> float: ...
    @property
    def verified(self) -> Optional[bool]: ...
    def eval(self, directions: npt.ArrayLike, channel: int = 0) -> npt.NDArray[np.float64]: ...
    def to_json(self) -> str:
        """The command line's fit JSON of this fit (`fit --json`)."""
    @staticmethod
    def from_json(text: str) -> "FitResult": ...

def load(
    path: PathLike,
    channel: Optional[str] = None,
    format: Optional[str] = None,
    negative: str = "mask",
) -> Dataset: ...
def from_arrays(
    directions: npt.ArrayLike,
    values: npt.ArrayLike,
    channels: Optional[Sequence[str]] = None,
    quantity: str = "brdf",
    weights: Optional[npt.ArrayLike] = None,
    negative: str = "mask",
) -> Dataset: ...
def fit(
    data: Data,
    model: str = "torrance-sparrow",
    *,
    distribution: str = "d3",
    loss: str = "log",
    method: str = "lm",
    robust: Optional[str] = None,
    max_theta: Optional[float] = None,
    weights: str = "file",
    fix: Optional[Mapping[str, float]] = None,
    start: Optional[Mapping[str, float]] = None,
    shared: Optional[Sequence[str]] = None,
    local_only: bool = False,
    resolution: float = 1e-6,
    verify: int = 0,
    verify_seed: int = 1,
    fast_pow: Optional[int] = None,
) -> Union[FitResult, List[FitResult]]: ...
def fit_all(data: Data, **options: Any) -> List[FitResult]: ...
def eval(
    model: str,
    params: Mapping[str, float],
    directions: npt.ArrayLike,
    distribution: Optional[str] = None,
) -> npt.NDArray[np.float64]: ...
def simulate(
    model: Optional[str] = None,
    params: Optional[Mapping[str, float]] = None,
    grid: str = "hemisphere:10000",
    directions: Optional[npt.ArrayLike] = None,
    distribution: str = "d3",
    noise: float = 0.0,
    seed: int = 1,
    nbrdf: Optional[PathLike] = None,
    material: Optional[str] = None,
    symmetric: bool = False,
) -> Dataset: ...
def choose(
    data: Data,
    scene: str = "fig7",
    threshold: str = "flip_p99=0.05",
    res: int = 512,
    verify: int = 4,
    allow_large_image: bool = False,
    output: Optional[PathLike] = None,
) -> Dict[str, Any]: ...
def render(scene: PathLike, allow_large_image: bool = False) -> npt.NDArray[np.float32]: ...
def export(
    fits: Union[FitResult, Iterable[FitResult]],
    to: str = "mitsuba",
    model: Optional[str] = None,
    distribution: Optional[str] = None,
    channel: Optional[str] = None,
    allow_unusable: bool = False,
    id: str = "brdfit",
) -> str: ...
def to_json(fits: Union[FitResult, Iterable[FitResult]]) -> str: ...
def read_fits(path_or_text: PathLike) -> List[FitResult]: ...
def model_names() -> List[Tuple[str, str]]: ...
def nbrdf_materials(path: PathLike) -> List[str]: ...
def keep_freed_memory() -> None: ...
