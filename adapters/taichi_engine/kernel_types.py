"""taichi types every kernel module shares: float64 scalars and vectors, 1-D ndarrays of them.
Importing this module initialises taichi (runtime.init_taichi) before any type is made."""
from .runtime import init_taichi

ti = init_taichi()
f64, i32, i64 = ti.f64, ti.i32, ti.i64
vec2 = ti.types.vector(2, f64)
vec3 = ti.types.vector(3, f64)
ivec2 = ti.types.vector(2, i32)
ivec3 = ti.types.vector(3, i32)
nd_vec2 = ti.types.ndarray(dtype=vec2, ndim=1)
nd_vec3 = ti.types.ndarray(dtype=vec3, ndim=1)
nd_f64 = ti.types.ndarray(dtype=f64, ndim=1)
nd_i32 = ti.types.ndarray(dtype=i32, ndim=1)
nd_i64 = ti.types.ndarray(dtype=i64, ndim=1)
