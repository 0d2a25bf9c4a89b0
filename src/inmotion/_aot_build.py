"""Build the ahead-of-time extension of :mod:`inmotion._aot` (a step of
``python -m inmotion.warmup``; needs numba and a C compiler).

::

    python -m inmotion._aot_build [--verbose]

It runs ``navigate --method sins`` and ``--method sins-dr`` (the command line's own code,
default configuration) on a short simulated drive, records each filter the engine builds
(its fill and accumulator functions, the numba types of its state, constants and the
arguments of :func:`inmotion.estimation.engine._advance`, its predict kernel's source) and
the arguments of :func:`inmotion.estimation.error_model._fill_F`, and compiles with
``numba.pycc`` (``target_cpu = 'host'``, as numba's JIT) one extension with, per case,
``advance_<i>`` (a wrapper that calls ``_advance`` with the case's fills and accumulators
as constant first-class functions: :func:`_function_value`), ``mode_<i>``,
``write_output_<i>``; per kernel ``kernel_address_<j>`` (the kernel lowered into the
extension from its source: :func:`_kernel_address_of`); and ``fill_F``,
``first_nonfinite_row``, ``first_not_increasing``. A manifest (JSON) beside it maps case
keys, kernel keys and argument types to the exports.

Before it is installed, the extension runs each case's first ``_advance`` call on copies of
its inputs and the result is compared with the JIT path's bit for bit; a difference (or any
failure) leaves no extension, so the runs keep the JIT path.
"""
from __future__ import annotations

import argparse
import contextlib
import copy
import importlib.machinery
import importlib.util
import io
import json
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from . import _aot

__all__ = ["build", "main"]

#: the drive the cases are recorded on (7 s: rest, accelerate, cruise; radar and barometer)
_DRIVE = {
    "name": "aot", "start": {"lat_deg": 34.2, "lon_deg": 108.9, "h_m": 380, "heading_deg": 30},
    "segments": [{"kind": "rest", "duration_s": 1},
                 {"kind": "accelerate", "to_speed_m_s": 3.0, "accel_m_s2": 1.0},
                 {"kind": "cruise", "duration_s": 3}],
    "imu": {"rate_hz": 100.0, "gyro": {"drift_deg_h": 0.01, "arw_deg_sqrt_h": 0.003},
            "accel": {"bias_ug": 100, "vrw_ug_sqrt_hz": 10}},
    "sensors": {"radar": {"rate_hz": 10.0, "noise_m_s": 0.1},
                "baro": {"rate_hz": 10.0, "noise_m": 0.5}}}
#: the methods whose run path is compiled ahead of time
METHODS = ("sins", "sins-dr", "od-velocity-kf")
#: the runs recorded: each method with its defaults, and sins-dr's other mode (its
#: measurement groups differ, so its filter is another case: paper 002 eq. 52); and sins-dr
#: with the paper's noise figures, whose scale factor ``dk`` is a first-order Markov process
#: (300 s; as with a simulated radar's ``scale_markov_*`` in meta.yaml, e.g. paper 002's hour):
#: ``F[dk, dk] = -1 / tau`` makes another predict kernel (16 active rows, not 15: the
#: recorded drive's radar has no scale-factor spec, so its ``dk`` is a random constant).
#: Without it a run on such a bundle loaded that kernel with numba (~0.55 s CPU).
#: And ``align --method od-velocity-kf`` at issue 13's equal workload as
#: ``benchmarks/bench_engine.py`` runs it (19 states, the sensor's velocity and the NHC, no
#: barometer; a Markov ``dk`` as the hour's radar states): its fills and predict kernel
#: (mounting block, 19 states) are another case (without it the run loads numba, ~0.5 s).
#: And sins-dr in both modes with the mounting angles as states (25 states), what it runs on
#: a bundle whose meta.yaml gives no mounting (``sins_dr.estimates_mounting``: a real log).
RUNS = (("sins",), ("sins-dr",), ("sins-dr", "--set", "mode=velocity-position"),
        ("sins-dr", "--set", "noise_preset=paper"),
        ("sins-dr", "--set", "estimate_mounting=true"),
        ("sins-dr", "--set", "estimate_mounting=true", "--set", "mode=velocity-position"),
        ("od-velocity-kf", "--set", "noise_preset=paper", "--set", "use_baro=false"))


def _fn_name(f) -> str:
    """``module.qualname`` of a fill / accumulator (a ``Compiled`` or a numba function)."""
    py = getattr(f, "py_func", f)
    return f"{py.__module__}.{py.__qualname__}"


def _record(runs=RUNS):
    """Run ``navigate --method M [OPTIONS]`` for each of ``runs`` on :data:`_DRIVE` with the JIT
    path and record the filters and the numba functions called through
    :func:`inmotion._aot.call`: ``(cases, calls)``, ``cases`` a list of dicts (filter, its
    first ``_advance`` call's arguments before and after), ``calls`` ``{name: (function,
    first arguments)}``."""
    from . import registry
    from .cli import main as cli
    from .estimation import engine as E
    from .io.bundle import write_bundle
    from .sim import simulate
    from .sim.scenario import load_scenario

    _aot._state["module"] = None                    # this process: the JIT path only
    cases, calls = [], {}
    orig_call, orig_common = E.ErrorStateFilter._call_advance, _aot.call

    def call(self, *args):
        first = not any(c["filter"] is self for c in cases)
        before = copy.deepcopy((self._S, args)) if first else None
        r = orig_call(self, *args)
        if first:
            cases.append({"filter": self, "before": before, "r": r,
                          "after": copy.deepcopy((self._S, args))})
        return r

    def common(name, jit, *args):
        calls.setdefault(name, (jit, copy.deepcopy(args)))
        return orig_common(name, jit, *args)

    E.ErrorStateFilter._call_advance, _aot.call = call, common
    try:
        with tempfile.TemporaryDirectory(prefix="inmotion-aot-") as tmp:
            b = Path(tmp) / "b"
            write_bundle(simulate(load_scenario(_DRIVE), np.random.default_rng(0)), b,
                         fmt="parquet")
            for i, (m, *opts) in enumerate(runs):   # the command line's own code path
                kind = registry.get(m).kind          # navigate or align
                try:
                    with contextlib.redirect_stdout(io.StringIO()):
                        cli.cli.main(args=["-q", kind, str(b), "--method", m, *opts,
                                           "-o", str(Path(tmp) / f"run{i}")],
                                     prog_name="inmotion")
                except SystemExit as e:
                    if e.code:
                        raise RuntimeError(f"{kind} --method {m} {' '.join(opts)} failed "
                                           f"({e.code})") from e
    finally:
        E.ErrorStateFilter._call_advance, _aot.call = orig_call, orig_common
    return cases, calls


def _function_value(disp, sig):
    """An intrinsic ``() -> FunctionType(sig)``: the compiled function ``disp`` as a
    first-class function value, its addresses taken in the extension (no Python object:
    the JIT path's values are unboxed from the dispatcher, with the same two addresses, and
    called through the same code, :mod:`numba.experimental.function_type`)."""
    from numba import types
    from numba.core import cgutils
    from numba.extending import intrinsic

    fnty = types.FunctionType(sig)

    @intrinsic
    def value(typingctx):
        def codegen(context, builder, signature, args):
            cres = disp.overloads[sig.args]
            sfunc = cgutils.create_struct_proxy(fnty)(context, builder)
            vp = context.get_value_type(types.voidptr)
            cfn = cgutils.get_or_insert_function(
                builder.module, context.get_value_type(fnty.ftype).pointee,
                cres.fndesc.llvm_cfunc_wrapper_name)
            sfunc.c_addr = builder.bitcast(cfn, vp)
            sfunc.py_addr = cgutils.get_null_value(vp)
            sfunc.jit_addr = builder.bitcast(context.declare_function(builder.module,
                                                                      cres.fndesc), vp)
            context.active_code_library.add_linking_library(cres.library)
            return sfunc._getvalue()
        return fnty(), codegen

    return value


def _kernel_address_of(src: str):
    """An intrinsic ``() -> int64``: the address of the predict kernel of source ``src``
    (:func:`inmotion.estimation.predict.kernel_source`) compiled into the extension.

    The kernel is lowered here, in the extension's own module, from its source with the
    ``numba.cfunc``'s options (``fastmath={'contract'}``, ``error_model='numpy'``), so LLVM
    optimizes it once, as the JIT does. Linked from numba's JIT-compiled (already optimized)
    module instead, it was optimized a second time and some sums' first two products fused
    into an FMA the other way: last-bit differences (measured on ``sins-dr``)."""
    import llvmlite.ir as ir
    from numba import types
    from numba.core import cgutils
    from numba.core.compiler import Flags, compile_extra
    from numba.core.cpu import FastMathOptions
    from numba.core.registry import cpu_target
    from numba.extending import intrinsic

    head, body = src.split("@numba.cfunc(", 1)
    ns: dict = {}                              # the kernel's function, without its decorator
    exec(compile(head + body[body.index("def kernel("):], "<predict kernel>", "exec"), ns)
    py = ns["kernel"]
    D = types.CPointer(types.float64)
    args = (D, D, D, D, types.float64, D)

    @intrinsic
    def address(typingctx):
        def codegen(context, builder, signature, a):
            fl = Flags()
            fl.no_compile = True
            fl.no_cpython_wrapper = True
            fl.no_cfunc_wrapper = False
            fl.fastmath = FastMathOptions({"contract"})
            fl.error_model = "numpy"
            cres = compile_extra(cpu_target.typing_context, context, py, args, types.void,
                                 fl, locals={}, library=context.active_code_library)
            dbl = ir.DoubleType()
            cfty = ir.FunctionType(ir.VoidType(), [dbl.as_pointer()] * 4
                                   + [dbl, dbl.as_pointer()])
            fn = cgutils.get_or_insert_function(builder.module, cfty,
                                                cres.fndesc.llvm_cfunc_wrapper_name)
            return builder.ptrtoint(fn, context.get_value_type(types.int64))
        return types.int64(), codegen

    return address


def _equal(a, b) -> bool:
    """Bit-for-bit equality of nested tuples of arrays and scalars."""
    if isinstance(a, tuple):
        return len(a) == len(b) and all(_equal(x, y) for x, y in zip(a, b))
    if isinstance(a, np.ndarray):
        return (a.shape == b.shape and a.dtype == b.dtype
                and a.tobytes() == np.ascontiguousarray(b).tobytes())
    return a == b


def _outputs(O):
    """The rows of an output buffer ``O`` that a call wrote (the rest is uninitialized)."""
    k, r = int(O.n[0]), int(O.nrec[0])
    rec = {"rec_t", "rec_phi", "rec_ppred", "rec_x", "rec_p", "rec_fed", "rec_xs",
           "rec_epoch"}
    return tuple(v[:r] if f in rec else v if f in ("n", "nrec") else v[:k]
                 for f, v in zip(O._fields, O))


def build(out_dir=None, verbose: bool = False) -> Path:
    """Compile the extension for the current sources (:func:`inmotion._aot.source_key`) into
    ``out_dir`` (default: the first writable of :func:`inmotion._aot.aot_dirs`); returns the
    extension's path. Raises when it cannot be built or is not bit-identical to the JIT."""
    from numba import types
    from numba.pycc import CC

    from .estimation import engine as E
    from .estimation import measurements as MS
    from .estimation import predict as PR

    if not any(shutil.which(c) for c in (os.environ.get("CC", "cc"), "cc", "gcc")):
        raise RuntimeError("no C compiler (cc, gcc) on the PATH")
    key = _aot.source_key()         # before anything is compiled: an edit meanwhile -> stale
    cases, calls = _record()
    name = _aot.EXT_PREFIX + key
    typeof = E._advance.typeof_pyval
    man = {"format": _aot.FORMAT, "key": key, "cases": {}, "kernels": {}, "common": {}}
    g: dict = {"_advance": E._advance, "_mode": E._mode, "_write_output": E._write_output}
    code = []
    exports = []                                     # (name, signature)
    kernels: dict = {}
    seen = {}
    for c in cases:
        f = c["filter"]
        fills = [_fn_name(x) for x in f._fill_objs]
        accs = [_fn_name(x) for x in f._acc_objs]
        ck = _aot.case_key(fills, accs, f._S, f._C)
        src = PR.kernel_source(f._C.ws.F_pattern, f._C.ws.Qc_pattern, f._C.ws.order)
        kk = PR.kernel_key(src)
        if kk not in kernels:              # per run: one case may run on several kernels
            j = kernels[kk] = len(kernels)
            g[f"_kaddr{j}"] = _kernel_address_of(src)
            code.append(f"def kernel_address_{j}():\n    return _kaddr{j}()\n")
            exports.append((f"kernel_address_{j}", types.int64()))
            man["kernels"][kk] = f"kernel_address_{j}"
        if ck in seen:
            c["index"] = seen[ck]
            continue
        i = seen[ck] = c["index"] = len(seen)
        for k, d in enumerate(f._fills):
            g[f"_f{i}_{k}"] = _function_value(d, MS.FILL_SIG)
        for k, d in enumerate(f._accs):
            g[f"_a{i}_{k}"] = _function_value(d, MS.ACC_SIG)
        nf, na = len(f._fills), len(f._accs)
        args = c["before"][1]
        argn = [f"x{k}" for k in range(len(args))]
        code.append(
            f"def advance_{i}(S, C, {', '.join(argn)}):\n"
            f"    fills = ({', '.join(f'_f{i}_{k}()' for k in range(nf))},)\n"
            f"    accs = ({', '.join(f'_a{i}_{k}()' for k in range(na))},)\n"
            f"    return _advance(S, C, fills, accs, {', '.join(argn)})\n"
            f"def mode_{i}(S, C):\n    return _mode(S, C)\n"
            f"def write_output_{i}(S, C, O, t, x_g, P_g):\n"
            f"    _write_output(S, C, O, t, x_g, P_g)\n")
        tS, tC = typeof(f._S), typeof(f._C)
        targs = [typeof(a) for a in args]
        O = args[11]
        n = f.layout.n
        exports += [
            (f"advance_{i}", E._advance.overloads[
                (tS, tC, typeof(f._fills), typeof(f._accs), *targs)].signature.return_type(
                tS, tC, *targs)),
            (f"mode_{i}", types.int64(tS, tC)),
            (f"write_output_{i}", types.none(tS, tC, typeof(O), types.float64,
                                             types.float64[::1], types.float64[:, ::1]))]
        man["cases"][ck] = {"index": i, "fills": fills, "accs": accs,
                            "args": [_aot.type_spec(a) for a in args],
                            "out": _aot.type_spec(O), "n": n}
    for fname, (jit, a) in calls.items():      # numba functions called from Python
        g[f"_{fname}"] = jit
        an = ", ".join(f"a{k}" for k in range(len(a)))
        code.append(f"def {fname}({an}):\n    return _{fname}({an})\n")
        ta = tuple(typeof(x) for x in a)
        exports.append((fname, jit.overloads[ta].signature.return_type(*ta)))
        man["common"][fname] = [_aot.type_spec(x) for x in a]
    from .core import _kernels as K
    g["_fnr"], g["_fni"] = K.first_nonfinite_row, K.first_not_increasing
    code.append("def first_nonfinite_row(a):\n    return _fnr(a)\n"
                "def first_not_increasing(t):\n    return _fni(t)\n")
    exports += [("first_nonfinite_row", types.int64(types.float64[:, :])),
                ("first_not_increasing", types.int64(types.float64[:]))]
    man["common"]["first_nonfinite_row"] = [2]
    man["common"]["first_not_increasing"] = [1]
    exec(compile("".join(code), "<inmotion aot wrappers>", "exec"), g)

    with tempfile.TemporaryDirectory(prefix="inmotion-aot-build-") as tmp, _releasing_gil():
        cc = CC(name)
        cc.target_cpu = "host"            # as numba's JIT: the CPU's FMA, AVX
        cc.output_dir = tmp
        cc.verbose = verbose
        for ex, sig in exports:
            cc.export(ex, sig)(g[ex])
        cc.compile()
        suffix = importlib.machinery.EXTENSION_SUFFIXES[0]
        built = Path(tmp) / f"{name}{suffix}"
        if not built.is_file():
            built = next(Path(tmp).glob(f"{name}*.so"))
        _check(built, name, cases, man)
        return _install(built, man, name, out_dir)


@contextlib.contextmanager
def _releasing_gil():
    """While the extension is compiled, its exported functions release the GIL on entry and
    take it back on return, as ``@njit(nogil=True)`` functions do (``numba.pycc`` has no
    option for it: its compiler's ``Flags`` are given ``release_gil``). They are nopython
    code on the arrays they are passed, touching no Python object. The command line reads
    the next IMU rows in a reader thread (:func:`inmotion.io.bundle_stream.read_ahead`)
    while the engine's loop runs: with the GIL held that thread could not run meanwhile."""
    from numba.pycc import compiler as pycc_compiler
    base = pycc_compiler.Flags

    class Flags(base):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            self.release_gil = True

    pycc_compiler.Flags = Flags
    try:
        yield
    finally:
        pycc_compiler.Flags = base


def _check(path: Path, name: str, cases, man):
    """Run each case's first ``_advance`` call through the extension on copies of its inputs;
    raise unless every output equals the JIT path's bit for bit."""
    from .estimation import predict as PR
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    addr = {k: int(getattr(mod, v)()) for k, v in man["kernels"].items()}
    for c in cases:
        f = c["filter"]
        ws = f._C.ws
        kk = PR.kernel_key(PR.kernel_source(ws.F_pattern, ws.Qc_pattern, ws.order))
        C = f._C._replace(ws=f._C.ws._replace(kernel=addr[kk]))     # the extension's kernel
        S, args = copy.deepcopy(c["before"])
        r = getattr(mod, f"advance_{c['index']}")(S, C, *args)
        S2, args2 = c["after"]
        if not (r == c["r"] and _equal(S, S2)
                and _equal(_outputs(args[11]), _outputs(args2[11]))):
            raise RuntimeError(f"the ahead-of-time {f.layout!r} filter differs from the JIT's")


def _install(built: Path, man: dict, name: str, out_dir) -> Path:
    """Copy the extension and then its manifest (which makes it visible) into the first
    writable directory; older extensions there are removed."""
    dirs = [Path(out_dir)] if out_dir is not None else list(_aot.aot_dirs())
    for d in dirs:
        try:
            d.mkdir(parents=True, exist_ok=True)
            for old in d.glob(_aot.EXT_PREFIX + "*"):
                if not old.name.startswith(name):
                    old.unlink()
            dest = d / built.name
            tmp = d / f".{built.name}.{os.getpid()}"
            shutil.copyfile(built, tmp)
            os.replace(tmp, dest)
            mtmp = d / f".{name}.json.{os.getpid()}"
            mtmp.write_text(json.dumps(man, indent=1))
            os.replace(mtmp, d / f"{name}.json")
            return dest
        except OSError:
            continue
    raise OSError("no writable directory for the ahead-of-time extension; set "
                  "INMOTION_AOT_DIR")


def main(argv=None) -> int:
    """``python -m inmotion._aot_build``: build, print one line; exit 1 on failure."""
    p = argparse.ArgumentParser(prog="python -m inmotion._aot_build",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("--verbose", action="store_true")
    p.add_argument("--out", default=None, help="directory (default: beside the package)")
    a = p.parse_args(argv)
    t0 = time.perf_counter()
    try:
        path = build(a.out, a.verbose)
    except Exception as e:                       # noqa: BLE001  (any failure: JIT fallback)
        print(f"inmotion: ahead-of-time kernels not built ({type(e).__name__}: "
              f"{str(e).splitlines()[0] if str(e) else ''}); runs use numba's JIT",
              flush=True)
        return 1
    print(f"inmotion: ahead-of-time kernels built in {time.perf_counter() - t0:.0f} s: "
          f"{path}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
