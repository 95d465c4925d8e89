"""TSL from Python: compile shaders, shade numpy arrays of points, render scenes.

>>> import numpy as np, tsl
>>> program = tsl.compile(source="material m = lambert(kd: gray(0.5));")
>>> m = program.material("m")
>>> up = np.array([[0.0, 0.0, 1.0]])
>>> m.reflection(up, up)  # kd / pi
array([[0.15915494, 0.15915494, 0.15915494]], dtype=float32)

`tsl.compile` returns a `Program`; `program.shader(name).instance(**values)`
gives an `Instance` whose parameters `set(**values)` changes without
recompiling; a `Material` or `Instance` shades arrays (`reflection`,
`sample`, `pdf`, `emission`) with the GIL released; `program.generator(name)`
calls a generator over arrays; `tsl.render` renders a scene file to an array.
"""

from ._tsl import (
    BsdfSample,
    CompileError,
    Diagnostic,
    Error,
    Generator,
    Instance,
    Material,
    Parameter,
    ParameterError,
    Program,
    Shader,
    compile,
    read_exr,
    render,
)

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
