"""Type stubs of the extension module `tsl._tsl` (re-exported by `tsl`)."""

from __future__ import annotations

import os
from typing import Any, Callable, Literal, NamedTuple, Optional, Sequence, Tuple, Union, final, overload

import numpy as np
import numpy.typing as npt

_Array = npt.ArrayLike
"""An array of N points ((N, 3) for vectors, (N,) for numbers), or one value for all."""
_F32 = npt.NDArray[np.float32]
_Path = Union[str, os.PathLike[str]]
_Value = Union[float, int, bool, str, Sequence[float], "Instance"]

__all__ = [
    "BsdfSample",
    "CompileError",
    "Diagnostic",
    "Error",
    "Generator",
    "Instance",
    "Material",
    "Parameter",
    "ParameterError",
    "Program",
    "Shader",
    "compile",
    "read_exr",
    "render",
]

class Error(Exception):
    """Base class of TSL's errors: `str(e)` is the rustc-style text."""

    diagnostics: list[Diagnostic]

class CompileError(Error):
    """A program that does not compile, or a name it does not define."""

class ParameterError(Error):
    """A value a shader instance refuses (unknown name, wrong type, string outside the options)."""

@final
class Diagnostic:
    """One diagnostic of an error."""

    @property
    def file(self) -> Optional[str]: ...
    @property
    def line(self) -> int: ...
    @property
    def column(self) -> int: ...
    @property
    def message(self) -> str: ...
    @property
    def severity(self) -> str: ...

class BsdfSample(NamedTuple):
    """What `Material.sample` returns, over N points."""

    wi: _F32
    """(N, 3) sampled directions (zero where the material drew nothing)."""
    weight: _F32
    """(N, 3) linear RGB: reflection x cosine / pdf."""
    pdf: _F32
    """(N,) solid-angle densities (0 for a delta lobe)."""
    delta: npt.NDArray[np.bool_]
    """(N,) whether each direction is a delta lobe's."""

def compile(
    path: Optional[_Path] = None,
    source: Optional[str] = None,
    color_model: str = "rgb",
    name: str = "<source>",
    include: Sequence[_Path] = (),
) -> Program:
    """Compiles a TSL program from a file or from text; `tsl.CompileError` on errors.

    `color_model`: "rgb", "spectral"/"hero", "spectralN" or "smitsN", as the CLI's `--color`.
    """

_Layers = dict[str, npt.NDArray[Any]]

@overload
def render(
    path: _Path,
    spp: Optional[int] = None,
    res: Optional[Tuple[int, int]] = None,
    seed: Optional[int] = None,
    integrator: Optional[str] = None,
    color: Optional[str] = None,
    aov: Literal[False] = False,
    include: Sequence[_Path] = (),
    progress: Optional[Callable[[int, int], object]] = None,
) -> _F32:
    """Renders a scene file as `tslc render` does: a (height, width, 3) float32 array."""

@overload
def render(
    path: _Path,
    spp: Optional[int] = None,
    res: Optional[Tuple[int, int]] = None,
    seed: Optional[int] = None,
    integrator: Optional[str] = None,
    color: Optional[str] = None,
    *,
    aov: Literal[True],
    include: Sequence[_Path] = (),
    progress: Optional[Callable[[int, int], object]] = None,
) -> Tuple[_F32, _Layers]:
    """With `aov=True`: the image and its layers (albedo, normal, depth, object)."""

@overload
def read_exr(path: _Path, aov: Literal[False] = False) -> _F32:
    """Reads an EXR (as `tslc render` writes them) as a (height, width, 3) float32 array."""

@overload
def read_exr(path: _Path, *, aov: Literal[True]) -> Tuple[_F32, _Layers]: ...

@final
class Program:
    """A compiled program; each material and generator compiles on first use."""

    @property
    def materials(self) -> list[str]:
        """The program's own materials and templates (not the prelude's), in definition order."""
    @property
    def color_model(self) -> str: ...
    @property
    def compiled_functions(self) -> int:
        """Functions compiled so far (unchanged by `Instance.set`)."""
    @property
    def shaders(self) -> list[Shader]:
        """Every material template, the prelude's included."""
    def shader(self, name: str) -> Shader: ...
    def material(self, name: str) -> Material: ...
    def generator(self, name: str) -> Generator: ...

@final
class Shader:
    """A material template: its parameters, and instances of it."""

    @property
    def name(self) -> str: ...
    @property
    def doc(self) -> Optional[str]: ...
    @property
    def parameters(self) -> list[Parameter]: ...
    def instance(self, **values: _Value) -> Instance:
        """An instance with `values` set by name, bound (it shades at once)."""

@final
class Parameter:
    """One parameter of a shader."""

    @property
    def name(self) -> str: ...
    @property
    def type(self) -> str:
        """As TSL writes it: "float", "color", "string", "color[4]"."""
    @property
    def default(self) -> Any:
        """The default evaluated (float, int, bool, str or tuple); None when required or not constant."""
    @property
    def default_source(self) -> Optional[str]: ...
    @property
    def doc(self) -> Optional[str]: ...
    @property
    def options(self) -> list[str]: ...
    @property
    def required(self) -> bool: ...

class Material:
    """A material's surface calls over arrays of N points (GIL released, all cores).

    Globals by name (`P`, `N`, `Ng`, `u`, `v`, `dPdu`, `face`, ...): (N, 3) / (N,) arrays or one
    value for all. `N` defaults to (0, 0, 1), `Ng` to `N`, `Pl` to `P`, `dPdu`/`dPdv` to a
    tangent frame around `N`, the rest to 0. Colors come back as linear RGB (a spectral
    program's converted point by point).
    """

    @property
    def name(self) -> str: ...
    def reflection(
        self, wi: _Array, wo: _Array, light: Optional[_Array] = None, *, eta: Optional[_Array] = None, **globals: _Array
    ) -> _F32:
        """(N, 3) light reflected toward `wo` from RGB `light` (white by default) arriving from `wi`."""
    def sample(self, wo: _Array, u1: _Array, u2: _Array, *, eta: Optional[_Array] = None, **globals: _Array) -> BsdfSample:
        """Samples a direction: `u1` (N,) picks the lobe, `u2` (N, 2) the direction in it."""
    def pdf(self, wi: _Array, wo: _Array, *, eta: Optional[_Array] = None, **globals: _Array) -> _F32:
        """(N,) solid-angle density of `sample` choosing `wi`."""
    def eval_pdf(
        self, wi: _Array, wo: _Array, *, eta: Optional[_Array] = None, **globals: _Array
    ) -> Tuple[_F32, _F32]:
        """`reflection` of white light and `pdf` in one call: ((N, 3) RGB, (N,))."""
    def emission(self, wo: _Array, *, eta: Optional[_Array] = None, **globals: _Array) -> _F32:
        """(N, 3) light emitted toward `wo`."""
    def albedo(self, wo: _Array, *, eta: Optional[_Array] = None, **globals: _Array) -> _F32:
        """(N, 3) fraction of light from `wo` reflected (the directional albedo)."""

@final
class Instance(Material):
    """A shader instance whose parameters are set at run time (no recompiling)."""

    def set(self, **values: _Value) -> Instance:
        """Sets parameters by name, all or none (`tsl.ParameterError`); returns the instance."""
    @property
    def values(self) -> dict[str, Any]: ...
    @property
    def source(self) -> str:
        """The TSL call the instance stands for: `rough_conductor(alpha: 0.5)`."""
    def specialise(self) -> Material:
        """The instance compiled with its values folded in as constants."""

@final
class Generator:
    """A generator (a function of plain values) called over arrays of points."""

    @property
    def name(self) -> str: ...
    @property
    def parameters(self) -> list[Tuple[str, str]]: ...
    @property
    def result_type(self) -> str: ...
    def __call__(self, *args: _Array, **kwargs: _Array) -> npt.NDArray[Any]:
        """Arguments by position or name; other keywords are shading globals.

        Returns (N,) for float, int and bool results, (N, 3) for vectors and colors (RGB),
        (N, 2) for vec2s.
        """
