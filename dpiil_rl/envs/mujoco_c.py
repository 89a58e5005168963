"""MuJoCo's C entry points, callable from numba-compiled code by address.

The ``mujoco`` Python package ships the shared library its bindings are linked against; loading it again
with ctypes returns the same library (the loader keeps one copy per process), so these functions act on the
``mjModel`` / ``mjData`` the bindings created, addressed by their ``_address``.

Compiled code gets each function's address as a plain integer argument and calls it through an intrinsic
(:func:`call_model_data`, :func:`call_jac_site`, :func:`call_full_m`) that casts the address to the C
signature of ``mujoco.h``. Handing numba the ctypes function objects instead costs ~100 us per call of the
compiled function (typing them), and referring to them as globals bakes their addresses into the machine
code, which then cannot be cached on disk; integer addresses avoid both.
"""

from __future__ import annotations

import ctypes
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Callable, cast

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

if TYPE_CHECKING:
    from numba.core.typing.templates import Signature

LIBRARY_SUFFIXES = {"linux": ".so", "darwin": ".dylib", "win32": ".dll"}


@dataclass(frozen=True)
class MujocoC:
    """Addresses of the C functions one substep of the fast step calls."""

    mj_step1: int  # void mj_step1(const mjModel* m, mjData* d): positions, velocities, qM, qfrc_bias
    mj_step2: int  # void mj_step2(const mjModel* m, mjData* d): actuation, acceleration, constraints, integration
    mj_jacSite: int  # void mj_jacSite(const mjModel* m, const mjData* d, mjtNum* jacp, mjtNum* jacr, int site)
    mj_fullM: int  # void mj_fullM(const mjModel* m, mjtNum* dst, const mjtNum* M): dense nv x nv inertia


def _library_path() -> Path:
    import mujoco  # noqa: PLC0415

    package = Path(mujoco.__file__).parent
    suffix = LIBRARY_SUFFIXES.get(sys.platform, ".so")
    candidates = sorted(package.glob(f"*mujoco*{suffix}*"))
    exact = [p for p in candidates if mujoco.__version__ in p.name]
    found = exact or candidates
    if not found:
        raise FileNotFoundError(f"mujoco {mujoco.__version__}: no shared library *mujoco*{suffix}* in {package}")
    return found[0]


def load_mujoco_c() -> MujocoC:
    """The addresses of the C functions in the MuJoCo library the ``mujoco`` bindings use."""
    library = ctypes.CDLL(str(_library_path()))

    def address(name: str) -> int:
        value = ctypes.cast(getattr(library, name), ctypes.c_void_p).value
        assert value is not None, f"{name}: a NULL address"  # an exported function has an address
        return int(value)

    return MujocoC(
        mj_step1=address("mj_step1"),
        mj_step2=address("mj_step2"),
        mj_jacSite=address("mj_jacSite"),
        mj_fullM=address("mj_fullM"),
    )


_VOID_P = ir.IntType(8).as_pointer()
_DOUBLE_P = ir.DoubleType().as_pointer()


def _integer_signature(*arguments: types.Type) -> Signature:
    """``void(arguments)``; addresses and indices reach the intrinsics as 64-bit integers of either sign."""
    for argument in arguments:
        # numba's stub of types.Integer leaves out its bitwidth (that of types.Float has it)
        if not isinstance(argument, types.Integer) or argument.bitwidth != 64:  # pyright: ignore[reportAttributeAccessIssue]
            raise TypeError(
                f"MuJoCo C call: argument of type {argument}: expected a 64-bit integer (an address or index)"
            )
    return types.void(*arguments)


def _pointer(builder: ir.IRBuilder, value: ir.Value, kind: ir.Type) -> ir.Value:
    return cast(ir.Value, builder.inttoptr(value, kind))  # llvmlite is untyped: its casts read as returning None


def _intrinsic(definition: Callable[..., object]) -> Callable[..., None]:
    """numba's ``intrinsic``, typed as compiled code calls the result: without the typing context (numba's stub
    keeps ``definition``'s signature, typing context included, and a call from Python raises)."""
    return intrinsic(definition)


@_intrinsic
def call_model_data(typingctx, function, model, data):  # type: ignore[no-untyped-def]
    """``function(model, data)`` for ``void f(const mjModel*, mjData*)`` (mj_step1, mj_step2)."""
    signature = _integer_signature(function, model, data)

    def codegen(context, builder, sig, args):  # type: ignore[no-untyped-def]
        fn_type = ir.FunctionType(ir.VoidType(), [_VOID_P, _VOID_P])
        fn = _pointer(builder, args[0], fn_type.as_pointer())
        builder.call(fn, [_pointer(builder, args[1], _VOID_P), _pointer(builder, args[2], _VOID_P)])
        return context.get_dummy_value()

    return signature, codegen


@_intrinsic
def call_jac_site(typingctx, function, model, data, jacp, jacr, site):  # type: ignore[no-untyped-def]
    """``mj_jacSite(model, data, jacp, jacr, site)``; ``site`` is passed as a C int."""
    signature = _integer_signature(function, model, data, jacp, jacr, site)

    def codegen(context, builder, sig, args):  # type: ignore[no-untyped-def]
        fn_type = ir.FunctionType(ir.VoidType(), [_VOID_P, _VOID_P, _DOUBLE_P, _DOUBLE_P, ir.IntType(32)])
        fn = _pointer(builder, args[0], fn_type.as_pointer())
        builder.call(
            fn,
            [
                _pointer(builder, args[1], _VOID_P),
                _pointer(builder, args[2], _VOID_P),
                _pointer(builder, args[3], _DOUBLE_P),
                _pointer(builder, args[4], _DOUBLE_P),
                builder.trunc(args[5], ir.IntType(32)),
            ],
        )
        return context.get_dummy_value()

    return signature, codegen


@_intrinsic
def call_full_m(typingctx, function, model, dst, qm):  # type: ignore[no-untyped-def]
    """``mj_fullM(model, dst, qM)``."""
    signature = _integer_signature(function, model, dst, qm)

    def codegen(context, builder, sig, args):  # type: ignore[no-untyped-def]
        fn_type = ir.FunctionType(ir.VoidType(), [_VOID_P, _DOUBLE_P, _DOUBLE_P])
        fn = _pointer(builder, args[0], fn_type.as_pointer())
        builder.call(
            fn,
            [
                _pointer(builder, args[1], _VOID_P),
                _pointer(builder, args[2], _DOUBLE_P),
                _pointer(builder, args[3], _DOUBLE_P),
            ],
        )
        return context.get_dummy_value()

    return signature, codegen
