"""Covariance predict specialised to F's sparsity pattern: code generated per pattern.

One filter epoch predicts ``x`` and ``P`` over ``dt`` with (:mod:`inmotion.estimation.kalman`,
:func:`~inmotion.estimation.kalman.discretize`)::

    Phi = I + F dt + (F dt)^2 / 2
    x  <- Phi x
    P  <- Phi P Phi^T + dt / 2 (Phi Qc Phi^T + Qc)      (symmetric, diagonal floored at 0)

(or ``Phi = I + F dt``: "First order" below).

The error model's ``F`` (:func:`error_model._fill_F`) is sparse and its pattern is fixed for a
run (:func:`error_model.F_pattern`: 58-115 nonzeros of n^2 = 361-625, all in the rows of the
dynamic blocks ``phi, dv, dp, phi_D, dp_D`` and of the Markov states, e.g. ``dk``); the
random-constant states (``eps, nabla, mount, lever``) have zero rows, i.e. identity rows of
``Phi``. With ``act`` the ``na`` "active" indices (F's nonzero rows) and ``Pt = P + dt/2 Qc``:

* ``Phi_a`` (the active rows of ``Phi``) ``= I_a + dt F_a + dt^2/2 F_aa F_a`` (``F_aa`` the
  active columns of ``F_a``: F's other rows are zero), entry by entry over its pattern;
* ``Phi P Phi^T + dt/2 Phi Qc Phi^T = Phi Pt Phi^T``, so ``Qc``'s entries are added to ``P``
  before the products, and once more after them (the trapezoid's ``+ dt/2 Qc``);
* ``A = Phi_a Pt`` (na x n) are the only rows of ``Phi Pt`` that differ from ``Pt``; they are
  formed row by row into a buffer (on the kernel's stack: below) whose rows are ``n``
  rounded up to a multiple of 4 (each
  row a sum of ``Phi_a[a, c] Pt[c, :]`` over whole 4-wide vectors, no scalar remainder; the
  padding columns read past the end of ``Pt``'s row and are never used; a row of ``Pt``
  whose padded read would pass the end of ``P`` itself, the last when its index is a column
  of ``Phi_a``, is read from a zero-padded copy of it on the stack: "Issue 13, vector
  widths" below);
  each row of ``Phi_a`` is formed right before its row of ``A`` (``Pt`` first): formed all
  at once, its ~115 entries (the engine workload's) were all live until the ``A`` pass and
  the compiled kernel spilled most of them to the stack (perf, issue 13: forming ``Phi_a``
  was 27 % of the kernel's samples, the ``A`` pass 36 %, ``R`` 22 %, the write of ``P'``
  17 %). The same sums in the same order: bit-identical (5 layouts, 30 chained steps from
  20 random ``P``); side by side, min of 7 batches of 20,000 calls, load ~5: the engine
  workload's kernel 0.626 -> 0.564 us a call, with a Gauss-Markov bias (na = 15) 1.08 ->
  0.90, ``sins-dr``'s 1.37 -> 1.39 and ``dr-kf``'s 1.59 -> 1.65 (about even). Tried and not
  kept: two or three rows of ``A`` per loop (``sins-dr`` 1.38 -> 1.24-1.27 us but the engine
  workload 0.56 -> 0.61-0.68); ``F``'s entries read where used instead of bound once (not
  bit-identical: LLVM fuses other products into FMAs); each row of ``P'`` read into locals
  before its stores (0.56 -> 0.59);
* ``P' = (Phi Pt) Phi^T``: between two active indices ``R = A Phi_a^T`` (its upper triangle,
  mirrored: ``P`` symmetric by construction; each row of ``R`` in loops over ``b`` from
  ``a`` rounded down to a multiple of 8 (the buffer's rows ``nap``, ``na`` rounded up to a
  multiple of 8: whole 512-bit vectors, "Issue 13, vector widths" below), split where the columns of ``Phi_a``'s rows change, each loop summing over its own rows'
  columns only: :func:`_segments`); between an active ``i`` and an inactive ``j``
  it is ``A[i, j]`` (copied into row ``i`` and column ``i``); between two inactive
  indices ``Pt`` (+ dt/2 Qc). ``P'`` is written row by row (contiguous stores; the mirrored
  entries are read strided from the buffers instead, which costs less than strided stores).
  The sums are those of the former in-place form term for term, so the results are
  bit-identical to it (issue 13, side by side, median of 9 batches of 20,000 calls at
  load 2.4: the engine workload's kernel 0.393 -> 0.363 us a call, ``sins-dr``'s 0.636 ->
  0.628 us; the write of ``P'`` 0.085 -> 0.049 us of the former). The longer source costs
  15-25 % more to compile (engine workload 2.6-2.9 -> 3.2-3.3 s CPU, ``sins-dr`` 5.7-5.8
  -> 6.8-7.0 s, once per pattern, at load ~2).

``A``, ``R`` and ``Phi_a x`` live in a buffer of the kernel's own, on its stack (an
``alloca`` through a numba intrinsic defined in the generated source); only ``Phi_a^T`` is
written to the workspace's ``buf`` (the smoother reads it). Issue 13: with every buffer behind
the raw pointer ``W``, LLVM could not rule out that ``W`` aliases ``P`` and guarded each loop
with a run-time overlap check and a scalar fallback copy of it; on the stack it knows they do
not: no checks, no fallback loops (machine code 3,009 -> 2,442 instructions for the engine
workload's kernel), and some copies into ``P'`` vectorized. The same sums in the same order:
bit-identical (the engine hour's filter state ``np.array_equal``; ``tests/test_predict.py``).
Speed: the kernel alone, in a loop, 0.395 -> 0.397 us a call (even); the engine's hour (one
process, the two kernels alternated, min of 7-15 runs each, AMD EPYC, 2 cores at load 5.6-9)
0.451 -> 0.440, 0.449 -> 0.417, 0.396 -> 0.379 and 0.383 -> 0.402 s per hour: even, within
this loaded machine's noise (+-10 % between runs), at best a few per cent. Kept for the
smaller code with no run-time checks, at no cost in results.

:func:`make_workspace` writes this as straight-line numba code for the one pattern it is given
(F's nonzeros and ``Phi_a``'s, ``n``, ``act`` and ``Qc``'s pattern are literals: every loop has
a constant trip count, every index a constant; about 3,700 multiply-adds for the 22-state
workload of issue 13, against 19,000 in the former BLAS form and 53,000 in the dense kernel),
compiles it once as a C callback (``numba.cfunc``, ``fastmath={'contract'}``: products and sums
fused into FMAs) and caches it on disk: the source is written to
``<kernel dir>/predict_<sha256 of the source>.py`` (kernel dir: ``$INMOTION_KERNEL_DIR``, else
``__pycache__/predict_kernels`` beside this file if writable, else the user's cache
directory) and numba caches the compiled code beside it, so a later process (and a later run
of the same layout) only loads it. A different pattern (another layout, a Markov bias, a DR)
gives a different source and file: the kernel follows whatever :func:`error_model.F_pattern`
reports. :func:`predict_sparse` calls the kernel through its address (one indirect call; the
engine's compiled loop is the same for every pattern and is compiled once).

The results equal the dense :func:`kalman._predict_kernel`'s to rounding (a test checks
1e-13 relative to the size of the terms, random SPD ``P``, dt from 0.005 to 1 s, F of every
layout the methods use and a pattern with a Gauss-Markov gyro bias); the order of the sums
differs, so the last bits do.

Cost (CPU time per call, minimum of 15 batches of 10,000-20,000 calls in a numba loop, a
2-core machine at load 7-9; ``benchmarks/bench_predict.py``): issue 13's engine workload
(n = 22, na = 9) 0.39-0.40 us (the former BLAS form 1.20 us, measured side by side; the dense
kernel 5.4 us); ``sins-dr`` (n = 22, na = 16, the DR's ``phi``-``phi_D`` noise) 0.69-0.70 us
(former 1.64-1.72 us); ``dr-kf`` (n = 25, na = 16) 0.79-0.83 us (former 1.59-1.74 us). The
machine code of the engine workload's kernel has ~430 4-wide and ~370 scalar FMAs: the
``A`` pass over 22 columns is 5 vector iterations and 2 scalar ones, ``Phi_a``'s 250 products
``F_aa F_a`` are scalar. Generating and compiling a kernel costs 1.5-3 s of CPU (n = 22,
na = 9) to 3-7 s (na = 16) on this loaded machine, once per pattern (the numba front end's
typing and lowering of ~650-1,200 statements is most of it; raw pointer indexing with
literal offsets halved it); loading it from the cache costs ~10 ms.

Why ``sins-dr``'s kernel costs ~2x the engine workload's for 6 more active rows (issue 13,
counted in the generated source): ``Phi_a`` has 171 entries against 115, the ``A`` pass
3,762 products against 2,760 (16 rows of ~11 columns against 9 of ~13, over 22 columns
each), and the ``R`` pass, quadratic in ``na``, 3,264 against 1,240, of which 1,247 were
needed: one loop per row of ``R`` summed over the union of all later rows' columns, so
the SINS rows' entries summed the DR rows' columns (and back) times exact zeros. Split
into loops of >= 8 rows (4-trip loops are unrolled by LLVM before its loop vectorizer and
left scalar: 0.37 -> 0.42 us for the engine workload's kernel) the ``R`` pass has 2,976;
machine code 1,589 -> 1,499 4-wide FMAs, the kernel 0.66-0.72 -> 0.61-0.67 us a call
(``dr-kf``'s 0.80-0.83 -> 0.75-0.80; the engine workload's code is unchanged: one segment),
side by side, five alternating rounds of the minimum of 7 batches of 20,000 calls, load
5.4-8.4: a small gain, 0-10 % a round; bit-identical to before (the
dropped terms are exact zeros; :func:`_zsum` keeps the FMA rounding of a sum whose first
term is dropped; checked on four layouts over 200 chained steps).

First order (``make_workspace(..., order=1)``, the engine's ``phi_order=1``; issue 13):
``Phi = I + F dt``, KF-GINS's own discretization (``insPropagation`` in its ``gi_engine.cpp``
forms ``Phi = I + F dt`` and the same trapezoid ``Q_d``), so the equal-workload benchmark can
run exactly KF-GINS's predict. ``Phi_a``'s pattern is then ``F_a``'s and the diagonal (67
entries for the engine workload's 22 states against 115; no ``F_aa F_a`` products), and the
``A`` pass shrinks with it; the ``R`` pass is unchanged (its loops span the union of the rows'
columns either way). The omitted ``(F dt)^2 / 2`` is ~``|F| dt / 2`` of ``F dt``, ~1e-4 at
100 Hz: on ``bench_engine.py``'s simulated hour positions differ by at most 1.0 mm (2.5e-4
of their sigma), attitudes by 1.3e-7 rad (1.0e-4 sigma) and sigmas by 2e-4 relative; on the
600 s drive of ``tests/test_engine.py`` 3.9 mm (9e-4 sigma) and 7e-7 rad (1.3e-4 sigma). The
default stays second order (the other methods' results are unchanged). Kernel cost, second
-> first order, side by side in one process (min of 25 batches of 4,000 calls, the minimum
over 7-9 alternating rounds): the engine workload's kernel 0.428 -> 0.376 us a call,
``sins-dr``'s 0.839 -> 0.683 us (load 2.9-4.2 on 2 cores, before the stack buffer above);
with it 0.365 -> 0.324 us and 0.783 -> 0.665 us (load ~8-9). The engine's hour, second ->
first order (one process, alternated, min of 7-15 runs, load 5.6-9): 0.440 -> 0.398,
0.417 -> 0.402, 0.379 -> 0.398, 0.402 -> 0.366 s; ``bench_engine.py`` at load ~10: 0.431 ->
0.369, 0.440 -> 0.413 s: typically 5-10 % less, within a noise of the same size.

Tried for the default second order and not kept (issue 13, this AVX-512 AMD EPYC; side by
side as above, load 2.3-3.4; all bit-identical to the kernel above):

* padding to 8 doubles (this CPU's 512-bit vectors) instead of 4: 0.394 -> 0.427 us. LLVM
  already runs each 12-trip loop as one 512-bit iteration and one masked one (``kmovd``);
  16-wide rows only add work. (No longer so with numba 0.68.1 / llvmlite 0.50, which leave
  the remainder scalar; kept since: "Issue 13, vector widths" below.);
* ``A = Pt_a + dt F_a Pt + dt^2/2 F_aa (F_a Pt)`` without ``Phi_a`` (counted, not built: 98
  products a column against ``Phi_a``'s 115, plus a pass over ``F_a Pt`` stored and read
  back, ~7 % of the ``A`` pass; ``Phi_a`` is still needed by the ``R`` pass and ``x``, so
  its formation stays): at most ~3 % of the kernel, below this machine's noise (+-10 %
  between rounds), and not bit-identical.

Issue 13, vector widths (this AMD EPYC, Zen 4: AVX-512, numba 0.68.1, llvmlite 0.50; counted
in the machine code of the compiled kernels): LLVM vectorizes a loop of constant trip count
8-wide (512-bit) and leaves the remainder scalar, unrolled: a 12-trip loop over ``b`` (the
``R`` and ``x`` passes of a 9-row ``Phi_a``, ``nap`` = 12) was one 8-wide iteration and four
scalar ones, and ``sins-dr``'s 22-trip ``A`` rows (``n`` = 22 and a last row of ``Pt`` that
a 24-wide read would pass the end of ``P`` with) five 4-wide and two scalar FMAs per term
instead of three 8-wide. Three changes, each bit-identical to the kernel before (``P``,
``x`` after 200 chained steps from a random ``P``, four layouts; the engine's hour, both
orders, its covariance ``np.array_equal``; ``sins-dr``'s hour, plain and smoothed, its
solution):

* the rows of ``Pt`` whose padded read would pass the end of ``P`` (the last, when it is a
  column of ``Phi_a``) are copied, zero-padded, to the stack and read there, so every row
  of ``A`` is whole vectors (``sins-dr``'s machine code 7,925 -> 6,665 instructions);
* ``nap`` and the starts of ``R``'s loops are multiples of 8 (``_VW``), not 4: no scalar
  remainder (the engine workload's first-order kernel 2,331 -> 1,437 instructions; the
  extra lanes read zero padding of ``Phi_a^T`` and write entries below ``R``'s diagonal that
  are never read; ``PhiT`` is 16 columns wide instead of 12 for 9 active rows);
* ``dt/2 Qc`` is added to the active block's entries of ``P'`` as they are written instead
  of by a read-modify-write after them (the same ``fma``).

Per call (``Phi_a`` order 2 unless said; minimum over 100 batches of 5,000 calls, the four
kernels interleaved batch by batch in one process; 2 cores shared with other jobs, load
2.6-3.5): before -> tail copy -> 8-aligned -> ``Qc`` folded:

=========================  ==========  ==========  ===========  ===========
kernel                     before      tail copy   8-aligned    Qc folded
=========================  ==========  ==========  ===========  ===========
engine workload (na = 9)   0.394 us    0.385       0.328        0.324
engine workload, order 1   0.340       0.342       0.226        0.220
``sins-dr`` (na = 16)      0.782       0.726       0.600        0.606
``dr-kf`` (n = 25, na 16)  0.804       0.831       0.752        0.756
=========================  ==========  ==========  ===========  ===========

(the tail copy changes only ``sins-dr``'s and ``dr-kf``'s code; ``Qc`` folded is even here,
-1 to -2 % in an earlier series at load ~5: 0.321 -> 0.317, 0.226 -> 0.222, 0.590 ->
0.577; before -> 8-aligned at load 7.5-8: 0.391 -> 0.351, 0.337 -> 0.224, 0.786 -> 0.642,
0.869 -> 0.788.) The engine's hour (``bench_engine.py``'s workload functions), the two
generators alternated in one process (``make_workspace`` swapped; CPU s per hour, min of
6-9 runs each, three series at load 5.7-7.2, 5.3-5.5 and 3.8-4.6): second order 0.325 ->
0.334, 0.374 -> 0.355, 0.324 -> 0.324 (even within this machine's noise: the kernel is
~0.12 s of the hour, -0.025 s expected); first order 0.325 -> 0.292, 0.355 -> 0.295,
0.337 -> 0.281; ``sins-dr`` at 100 Hz 0.632 -> 0.576, 0.698 -> 0.659, 0.615 -> 0.575.
A fourth series at load 1.5 (``benchmarks/ab_predict.py --hour``, against main): kernels
0.388 -> 0.322, 0.338 -> 0.215, 0.772 -> 0.575, 0.845 -> 0.747 us; the hour 0.306 -> 0.305,
0.295 -> 0.277, 0.576 -> 0.532 s. In the hour a kernel's gain shows as far as its machine
code shrank, not as far as its time in a tight loop did: the code is straight-line, 15-30
KB against a 32 KB instruction cache shared with the engine's loop, and the instructions
went 7,925 -> 3,830 for ``sins-dr``, 2,331 -> 1,437 for the first order, but only 2,357 ->
~2,280 for the second order (its ``R`` and ``x`` loops are most of what changed; ``Phi_a``'s
~365 scalar operations and the ~315 scalar stores of ``P'`` are unchanged), whose hour is
even in all four series although its kernel alone is 10-17 % faster.

Tried in the same way and not kept:

* ``Phi_a``'s rows formed 8-wide (``dt F[i, :] + dt^2/2 sum_j F[i, j] F[j, :]`` over whole
  rows into the stack, then read back as scalars): ``sins-dr`` 0.661 -> 0.808 us, the engine
  workload 0.375 -> 0.465 (rows of 24 mostly zero columns, every entry stored and reloaded);
* two partial sums per row of ``A`` (halved FMA chains): even (0.670 -> 0.656, 0.386 ->
  0.390) and not bit-identical: the kernel is bound by its instruction count, not by FMA
  latency;
* ``P'``'s entries copied from ``R``'s rows in loops where the active indices are
  contiguous: even (0.668 -> 0.660, 0.365 -> 0.365);
* LLVM's SLP vectorizer for the kernel alone (numba's ``SLP_VECTORIZE`` set while it is
  compiled; numba switched it off by default in 0.57 for miscompilations, numba PR 8852):
  with 4-aligned loops first order 0.342 -> 0.264 and ``sins-dr`` 0.662 -> 0.595 but
  second order 0.377 -> 0.469 us; with the 8-aligned ones all three slower (0.220 -> 0.245,
  0.601 -> 0.654, 0.323 -> 0.358);
* no AVX-512 (``NUMBA_CPU_FEATURES`` without ``avx512*``), 4-aligned: ``sins-dr`` 0.66 ->
  0.74-0.76, the engine workload even;
* counted, not built: ``A = Pt_a + dt F_a Pt + dt^2/2 F_aa (F_a Pt)`` without ``Phi_a``
  needs ``nnz(F_a) + nnz(F_aa) + 2 na`` terms a column, 116 against ``Phi_a``'s 115 for the
  engine workload and 199 against 171 for ``sins-dr`` (``Phi_a`` is still formed for ``R``,
  ``x`` and ``PhiT``); and ``sins-dr``'s Markov ``dk`` row (``F[dk, dk]`` alone) as a
  "diagonal" row class: its row of ``A`` is already one term, its column of ``R`` is summed
  by the DR rows' loop, which has the column ``dk`` anyway, and 15 rows leave ``nap`` at 16.

Rows of ``F`` outside the pattern, and entries of ``Qc`` outside its pattern, are ignored
(taken as zero); ``Qc``'s diagonal is always in its pattern. ``x``, ``P``, ``F``, ``Qc`` must
be C-contiguous float64 of the workspace's ``n`` (checked on every call: the kernel reads and
writes exactly ``n`` and ``n x n`` entries through raw pointers).

Usage (engine)::

    F = np.zeros((n, n))                                  # zeroed once (_fill_F assigns)
    ws = make_workspace(em.F_pattern(n, offs, inv_tau_dk, dr_eps), Qc != 0)
    ...                                                   # every epoch, in numba code:
    em._fill_F(F, offs, lat, h, vel_n, C, f_n, inv_tau_dk, dr_eps, grav_grad)
    predict_sparse(x, P, F, Qc, dt, ws)                   # x, P in place

The engine (:func:`inmotion.estimation.engine._advance`) checks the sizes once per call and
then calls :func:`predict_kernel_call` with the workspace's ``kernel`` and ``buf`` bound once
and its arrays as :func:`borrowed` views: the inlined :func:`predict_sparse` bound ``x``,
``P``, ``Qc`` views and the workspace's six arrays on every call, 20 atomic reference-count
operations a row (issue 13; ``borrowed``'s docstring).
"""
from __future__ import annotations

import hashlib
import importlib.util
import os
import sys
import tempfile
from collections import namedtuple
from pathlib import Path

import numpy as np

from .. import _aot
from .._jit import intrinsic, njit

__all__ = ["PredictWorkspace", "make_workspace", "predict_sparse", "kernel_source", "kernel_key",
           "borrowed", "predict_kernel_call"]

#: bump when the generated code changes meaning (the source's hash keys the cache anyway)
_GENERATOR = "predict-kernel 5"

_Fields = namedtuple("_Fields", [
    "act",        # (na,) int64: active indices (rows where F may be nonzero), ascending
    "inact",      # (n - na,) int64: the other indices (identity rows of Phi)
    "PhiT",       # (n, nap) float64: Phi's active rows, transposed, in its first na columns
                  # (written by every call; nap = na rounded up to a multiple of 8)
    "buf",        # (n nap,) float64: PhiT's data (R, Phi_a x and A are on the kernel's stack)
    "kernel",     # int: address of the compiled kernel (valid in this process)
    "F_pattern",  # (n, n) bool: the pattern the kernel was generated for
    "Qc_pattern",  # (n, n) bool: Qc's pattern (symmetric, with its diagonal)
    "order",      # int: Phi's order in F dt (2: I + F dt + (F dt)^2 / 2, 1: I + F dt)
])


class PredictWorkspace(_Fields):
    """The generated kernel of one pattern and its buffer (a namedtuple: numba takes it as
    is). Pickling rebuilds it from the patterns (the kernel's address is per process)."""

    __slots__ = ()

    def __reduce__(self):
        return make_workspace, (self.F_pattern, self.Qc_pattern, self.order)


# ------------------------------------------------------------------ code generation
def _phi_terms(Fm, act, order=2):
    """Per active row ``i``: ``{c: (in F, [j: F[i, j] F[j, c] terms])}`` over Phi_a's pattern
    (``order`` 1: no ``F F`` terms, Phi_a's pattern is F_a's and the diagonal)."""
    actset = set(int(i) for i in act) if order == 2 else set()
    n = Fm.shape[0]
    rows = []
    for i in act:
        i = int(i)
        cols = {}
        for c in range(n):
            prods = [j for j in range(n) if j in actset and Fm[i, j] and Fm[j, c]]
            if Fm[i, c] or prods or c == i:
                cols[c] = (bool(Fm[i, c]), prods)
        rows.append((i, cols))
    return rows


def _runs(idx):
    """Contiguous runs ``[(start, stop), ...]`` of sorted indices."""
    out = []
    for i in idx:
        i = int(i)
        if out and out[-1][1] == i:
            out[-1][1] = i + 1
        else:
            out.append([i, i + 1])
    return [tuple(r) for r in out]


def _sum(terms):
    return " + ".join(terms) if terms else "0.0"


#: the shortest loop over active rows the R pass splits off (a 4-trip loop is unrolled by LLVM
#: before its loop vectorizer runs, and its SLP vectorizer leaves the unrolled sums scalar:
#: measured 0.37 -> 0.42 us a call for the engine workload's kernel)
_MIN_SEGMENT = 8


def _cols_of(rows, lo, hi):
    """The columns of Phi_a's rows ``lo .. hi - 1`` (those that exist): the only ``c`` whose
    ``Phi_a^T[c, lo:hi]`` is not all zero."""
    return sorted(set().union(*[set(rows[b][1]) for b in range(lo, min(hi, len(rows)))]))


def _segments(rows, lo, hi):
    """Split ``lo .. hi`` (multiples of ``_VW``) into loops of >= ``_MIN_SEGMENT`` rows (or one loop)
    minimizing the products: a loop over rows ``b`` sums over the union of its rows' columns,
    adding exact zeros ``u_c * 0.0`` for the columns of other rows (issue 13: in ``sins-dr``'s
    layout one loop per R row summed the DR rows' columns into the SINS rows' entries and back,
    3,264 products for 1,247 needed; dropping an exact zero product changes no bit of a sum of
    finite terms)."""
    best = {hi: (0, [])}
    for p in range(hi - _VW, lo - 1, -_VW):
        cands = []
        for q in range(p + _VW, hi + 1, _VW):
            if q - p < _MIN_SEGMENT and not (p == lo and q == hi):
                continue
            if q not in best:
                continue
            c, segs = best[q]
            cands.append((c + (q - p) * len(_cols_of(rows, p, q)), len(segs) + 1,
                          [(p, q)] + segs))
        if cands:
            c, _, segs = min(cands, key=lambda t: (t[0], t[1]))
            best[p] = (c, segs)
    return best[lo][1]


def _zsum(term, full, cols):
    """The sum of ``term(c)`` over ``cols``, a subset of ``full`` whose
    other terms are exact zeros: written so that it rounds as the sum over ``full`` did.
    Under FMA contraction the first two products of a sum may fuse either way; when the
    first of ``full`` is dropped, the sum starts with ``0.0 +`` (as ``0 + t`` it was: the
    first kept product rounded alone, every later one fused), which LLVM may not fold
    without ``nsz``."""
    s = _sum([term(c) for c in cols])
    return "0.0 + " + s if cols and full and cols[0] != full[0] else s


#: the width (doubles) the loops over active rows (``R``, ``Phi_a x``) and ``nap`` are
#: aligned to: a 512-bit vector (module docstring, "Issue 13, vector widths"); with 4, a
#: 12-trip loop was one 8-wide iteration and four scalar ones
_VW = 8


def _pad(na, w=4):
    """``na`` rounded up to a multiple of ``w`` (4: whole 256-bit vectors, 8: 512-bit)."""
    return -(-na // w) * w


def kernel_source(F_pattern, Qc_pattern, order=2) -> str:
    """Python source of the predict kernel specialised to ``F_pattern`` and ``Qc_pattern``
    ((n, n) bool; ``Qc_pattern`` symmetric with its diagonal): the module docstring's
    algorithm with every index a literal. The module defines ``kernel``, a ``numba.cfunc``
    ``void(x*, P*, F*, Qc*, dt, buf*)``; ``buf`` holds ``Phi_a^T`` (n x nap), ``nap`` = na
    rounded up to a multiple of 8 (``_VW``; the pad columns stay zero) so that the loops over
    active indices are whole 8-wide vectors; ``R`` (na x nap), ``Phi_a x`` (nap), ``A`` (na
    rows of n rounded up to a multiple of 4) and the zero-padded copies of the rows of ``Pt``
    that ``A``'s pass would read past the end of ``P`` are in a buffer on the kernel's stack.
    ``order`` 1: ``Phi = I + F dt`` (no ``F F`` terms), else the module docstring's second
    order."""
    if order not in (1, 2):
        raise ValueError(f"order must be 1 or 2, got {order!r}")
    Fm = np.asarray(F_pattern, dtype=bool)
    Qm = np.asarray(Qc_pattern, dtype=bool)
    n = Fm.shape[0]
    act = np.flatnonzero(Fm.any(axis=1))
    inact = np.flatnonzero(~Fm.any(axis=1))
    na = len(act)
    nap = _pad(na, _VW)
    rows = _phi_terms(Fm, act, order)
    npad = _pad(n)                                # A's row length (whole 4-wide vectors)
    # R, Phi_a x and A = Phi_a Pt in the kernel's own stack buffer T (not the workspace's:
    # LLVM then knows that they alias none of the arguments; module docstring)
    roff, xoff = 0, na * nap
    aoff = xoff + nap
    # A's rows are formed over whole vectors: columns n..npad-1 read past the end of P's
    # row (harmless, never used); a row of Pt whose padded read would pass the end of P
    # itself (the last, when it is an active column) is read from a zero-padded copy of it
    # in T instead (issue 13: with a scalar remainder, n = 22 in 22-trip loops, LLVM formed
    # each row of A in five 4-wide and two scalar FMAs per term instead of three 8-wide)
    tail = sorted({c for _, cols in rows for c in cols if c * n + npad > n * n})
    toff = aoff + na * npad
    tsize = max(toff + len(tail) * npad, 1)

    def prow(c):
        if c in tail:
            return f"{B}[{toff + tail.index(c) * npad} + k]"
        return f"P[{c * n} + k]"
    B = "T"
    L = [f"# generated by inmotion.estimation.predict ({_GENERATOR}); do not edit",
         f"# n = {n}, active = {[int(i) for i in act]}",
         *(["# first-order Phi = I + F dt"] if order == 1 else []),
         "import numba",
         "from llvmlite import ir",
         "from numba import types",
         "from numba.core import cgutils",
         "from numba.extending import intrinsic",
         "",
         "_D = types.CPointer(types.float64)",
         "",
         "",
         "@intrinsic",
         "def _stack(typingctx):",
         "    # a buffer of the kernel's own: LLVM knows that it aliases none of the arguments",
         "    def codegen(context, builder, signature, args):",
         "        return cgutils.alloca_once(builder, context.get_value_type(types.float64),",
         f"                                   size=ir.Constant(ir.IntType(64), {tsize}))",
         "    return _D(), codegen",
         "",
         "",
         "@numba.cfunc(types.void(_D, _D, _D, _D, types.float64, _D), cache=True,",
         "             fastmath={'contract'}, error_model='numpy')",
         "def kernel(x, P, F, Qc, dt, W):",
         "    hdt = 0.5 * dt",
         "    hdt2 = 0.5 * dt * dt",
         "    T = _stack()"]
    q = [(int(i), int(j)) for i, j in zip(*np.nonzero(Qm))]
    qadd = [f"    P[{i * n + j}] += hdt * Qc[{i * n + j}]" for i, j in q]
    L.append("    # Pt = P + dt/2 Qc")
    L.extend(qadd)
    folded = set()
    if na:
        S = sorted(set().union(*[set(cols) for _, cols in rows]))
        if tail:
            L.append("    # the rows of Pt read past P's end by A's 4-wide pass, copied zero-padded")
        for t, c in enumerate(tail):
            L.append(f"    for k in range({n}):")
            L.append(f"        {B}[{toff + t * npad} + k] = P[{c * n} + k]")
            for k in range(n, npad):
                L.append(f"    {B}[{toff + t * npad + k}] = 0.0")
        L.append("    # F's entries")
        for i in act:
            for c in np.flatnonzero(Fm[i]):
                L.append(f"    f{i}_{c} = F[{i * n + c}]")
        L.append("    # per active row: its entries of Phi_a = I_a + dt F_a + dt^2/2 F_aa F_a (over")
        L.append("    # its pattern, into the buffer's Phi_a^T), then its row of A = Phi_a Pt along")
        L.append("    # whole 4-wide vectors")
        for a, (i, cols) in enumerate(rows):
            for c, (lin, prods) in cols.items():
                parts = ["1.0"] if c == i else []
                if lin:
                    parts.append(f"dt * f{i}_{c}")
                if prods:
                    parts.append("hdt2 * (" + _sum([f"f{i}_{j} * f{j}_{c}" for j in prods])
                                 + ")")
                L.append(f"    p{a}_{c} = {_sum(parts)}")
                L.append(f"    W[{c * nap + a}] = p{a}_{c}")
            L.append(f"    for k in range({npad}):")
            L.append(f"        {B}[{aoff + a * npad} + k] = "
                     + _sum([f"p{a}_{c} * {prow(c)}" for c in cols]))
        L.append(f"    # x <- Phi x ({_VW}-wide over the active rows, in loops over their own columns)")
        for c in S:
            L.append(f"    x{c} = x[{c}]")
        for lo, hi in _segments(rows, 0, nap):
            L.append(f"    for b in range({lo}, {hi}):")
            L.append(f"        {B}[{xoff} + b] = "
                     + _zsum(lambda c: f"x{c} * W[{c * nap} + b]", S, _cols_of(rows, lo, hi)))
        for a, (i, _) in enumerate(rows):
            L.append(f"    x[{i}] = {B}[{xoff + a}]")
        L.append(f"    # R = A Phi_a^T, R[a, b] for b >= a rounded down to a multiple of {_VW}, in loops")
        L.append("    # over b, each over the columns of its rows of Phi_a only")
        for a, (i, _) in enumerate(rows):
            b0 = a - a % _VW
            need = sorted(set().union(*[set(rows[b][1]) for b in range(b0, na)]))
            for c in need:
                L.append(f"    u{c} = {B}[{aoff + a * npad + c}]")
            for lo, hi in _segments(rows, b0, nap):
                L.append(f"    for b in range({lo}, {hi}):")
                L.append(f"        {B}[{roff + a * nap} + b] = "
                         + _zsum(lambda c: f"u{c} * W[{c * nap} + b]", need,
                                 _cols_of(rows, lo, hi)))
        L.append("    # P' = R on the active block (upper triangle mirrored), A mirrored on the")
        L.append("    # active-inactive one")
        # (row by row, so that the stores of each row are contiguous: the mirrored entries
        # are read strided instead, which is cheaper than storing them strided)
        for a, (i, _) in enumerate(rows):
            for b in range(na):
                lo = min(a, b)
                k = i * n + int(act[b])
                if Qm[i, act[b]]:                 # + dt/2 Qc here, not read back after
                    folded.add(k)
                    L.append(f"    P[{k}] = {B}[{roff + lo * nap + max(a, b)}] + hdt * Qc[{k}]")
                else:
                    L.append(f"    P[{k}] = {B}[{roff + lo * nap + max(a, b)}]")
            for lo, hi in _runs(inact):
                L.append(f"    for c in range({lo}, {hi}):")
                L.append(f"        P[{i * n} + c] = {B}[{aoff + a * npad} + c]")
        for lo, hi in _runs(inact):
            L.append(f"    for c in range({lo}, {hi}):")
            for a, (i, _) in enumerate(rows):
                L.append(f"        P[c * {n} + {i}] = {B}[{aoff + a * npad} + c]")
    L.append("    # + dt/2 Qc (where not added above); diagonal floored at 0")
    L.extend(f"    P[{i * n + j}] += hdt * Qc[{i * n + j}]" for i, j in q
             if i * n + j not in folded)
    L.append(f"    for i in range(0, {n * n}, {n + 1}):")
    L.append("        if P[i] < 0.0:")
    L.append("            P[i] = 0.0")
    return "\n".join(L) + "\n"


# ------------------------------------------------------------------ compile and cache
_KERNELS: dict = {}          # source hash -> numba CFunc (kept alive: its address is used)


def _kernel_dirs():
    env = os.environ.get("INMOTION_KERNEL_DIR")
    if env:
        yield Path(env)
    yield Path(__file__).resolve().parent / "__pycache__" / "predict_kernels"
    cache = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    yield Path(cache) / "inmotion" / "predict_kernels"
    yield Path(tempfile.gettempdir()) / f"inmotion-predict-kernels-{os.getuid()}"


def _write_source(src: str, key: str) -> Path:
    """The kernel's source file, written once (an unchanged file keeps its time stamp, which
    keeps numba's cache of it valid across processes)."""
    for d in _kernel_dirs():
        path = d / f"predict_{key}.py"
        try:
            if path.is_file() and path.read_text() == src:
                return path
            d.mkdir(parents=True, exist_ok=True)
            tmp = d / f".predict_{key}.{os.getpid()}.tmp"
            tmp.write_text(src)
            os.replace(tmp, path)            # atomic: a concurrent reader sees one version
            return path
        except OSError:
            continue
    raise OSError("no writable directory for the predict kernels; set INMOTION_KERNEL_DIR")


def kernel_key(src: str) -> str:
    """The key of a kernel source (its file name, and the ahead-of-time extension's index:
    :mod:`inmotion._aot`)."""
    return hashlib.sha256(src.encode()).hexdigest()[:24]


def _kernel(src: str):
    key = kernel_key(src)
    fn = _KERNELS.get(key)
    if fn is None:
        path = _write_source(src, key)
        name = f"inmotion_predict_{key}"
        spec = importlib.util.spec_from_file_location(name, path)
        mod = importlib.util.module_from_spec(spec)
        sys.modules[name] = mod          # numba's cache records (and reloads) it by name
        spec.loader.exec_module(mod)
        fn = _KERNELS[key] = mod.kernel
    return fn


def make_workspace(F_pattern, Qc_pattern=None, order=2) -> PredictWorkspace:
    """The predict kernel of one F / Qc pattern (generated, compiled and cached on first use)
    and its buffer; once per filter.

    Parameters
    ----------
    F_pattern : (n, n) array, nonzero where F may be nonzero (e.g.
        :func:`inmotion.estimation.error_model.F_pattern`, or ``F != 0`` of F at a generic
        state); its zero rows are the identity rows of ``Phi``
    Qc_pattern : (n, n) array, nonzero where Qc may be nonzero (default: the diagonal only);
        the diagonal is always included, and the pattern is symmetrized
    order : 2 (default): ``Phi = I + F dt + (F dt)^2 / 2``; 1: ``Phi = I + F dt`` (KF-GINS's
        discretization: module docstring, "First order")

    Returns
    -------
    PredictWorkspace : a namedtuple, passed as is to :func:`predict_sparse` (also from numba
        code); one per filter (its buffer is overwritten by each call)
    """
    Fm = np.asarray(F_pattern) != 0
    if Fm.ndim != 2 or Fm.shape[0] != Fm.shape[1]:
        raise ValueError(f"F_pattern must be square, got {Fm.shape}")
    n = Fm.shape[0]
    Qm = np.eye(n, dtype=bool)
    if Qc_pattern is not None:
        q = np.asarray(Qc_pattern) != 0
        if q.shape != (n, n):
            raise ValueError(f"Qc_pattern must be ({n}, {n}), got {q.shape}")
        Qm |= q | q.T
    rows = Fm.any(axis=1)
    act = np.flatnonzero(rows).astype(np.int64)
    inact = np.flatnonzero(~rows).astype(np.int64)
    na = len(act)
    if order not in (1, 2):
        raise ValueError(f"order must be 1 or 2, got {order!r}")
    src = kernel_source(Fm, Qm, order)
    addr = _aot.kernel_address(kernel_key(src))      # compiled ahead of time (no numba)
    if addr is None:
        addr = _kernel(src).address
    nap = _pad(na, _VW)
    buf = np.zeros(max(n * nap, 1))
    return PredictWorkspace(act, inact, buf[:n * nap].reshape(n, nap), buf, int(addr), Fm, Qm,
                            int(order))


# ------------------------------------------------------------------ the call
@intrinsic
def _call_kernel(typingctx, addr, x, P, F, Qc, dt, buf):
    """Call the kernel at ``addr`` with the arrays' data pointers (C-contiguous float64)."""
    from llvmlite import ir as llvm_ir
    from numba import types
    from numba.core import errors as nb_errors
    for a, nd in ((x, 1), (P, 2), (F, 2), (Qc, 2), (buf, 1)):
        if not (isinstance(a, types.Array) and a.dtype == types.float64 and a.ndim == nd
                and a.layout == "C"):
            raise nb_errors.TypingError(f"predict_sparse: expected a C-contiguous float64 "
                                        f"{nd}-d array, got {a}")
    if not isinstance(addr, types.Integer) or not isinstance(dt, types.Float):
        raise nb_errors.TypingError("predict_sparse: kernel address int, dt float")
    sig = types.none(addr, x, P, F, Qc, dt, buf)

    def codegen(context, builder, signature, args):
        dbl = llvm_ir.DoubleType()
        ptr = dbl.as_pointer()
        fnty = llvm_ir.FunctionType(llvm_ir.VoidType(), [ptr, ptr, ptr, ptr, dbl, ptr])
        data = []
        for ty, val in zip(signature.args[1:], args[1:]):
            if isinstance(ty, types.Array):
                data.append(context.make_array(ty)(context, builder, val).data)
            else:
                data.append(context.cast(builder, val, ty, types.float64))
        fn = builder.inttoptr(args[0], fnty.as_pointer())
        builder.call(fn, data)
        return context.get_dummy_value()

    return sig, codegen


def _borrow_value(context, builder, ty, val):
    """``val`` of type ``ty`` with every array in it (also inside tuples) made a borrowed
    view (NULL meminfo); other members are passed on with a reference of their own."""
    from numba import types
    from numba.np.arrayobj import populate_array
    if isinstance(ty, types.Array):
        src = context.make_array(ty)(context, builder, val)
        out = context.make_array(ty)(context, builder)
        populate_array(out, data=src.data, shape=src.shape, strides=src.strides,
                       itemsize=src.itemsize, meminfo=None)
        return out._getvalue()
    if isinstance(ty, types.BaseTuple):
        vals = [_borrow_value(context, builder, t, builder.extract_value(val, i))
                for i, t in enumerate(ty.types)]
        return context.make_tuple(builder, ty, vals)
    context.nrt.incref(builder, ty, val)
    return val


@intrinsic
def borrowed(typingctx, arr):
    """A view of ``arr`` (same type, data, shape and strides) that does not own a reference:
    its meminfo is NULL, so numba's reference counting of it (an ``NRT_incref`` /
    ``NRT_decref`` call wherever the view is bound, sliced, indexed to a sub-array or passed
    to a function that binds it) skips the atomic increment: a test of NULL instead of a
    ``lock inc``. A tuple (or namedtuple) gives the same tuple with each of its arrays
    borrowed (recursively); other members are passed on as they are.

    Issue 13: the engine's per-row path made 33 such atomic operations per IMU row (counted
    with gdb at ``NRT_incref`` / ``NRT_decref``: 20 around the predict call, for ``X[l]``,
    ``P[l]``, ``Qc[l]``, ``F`` and the workspace's six arrays, 6 in the mechanization, 6 in
    ``_fill_F``), ~0.09 s of the 0.35 s per hour (perf), an update epoch ~107 more and an
    output epoch (a call with the namedtuples of ~50 arrays each) ~390. Valid only while
    ``arr`` is alive: for a compiled function's own arrays (e.g. a state namedtuple's
    fields, alive for the call) bound at its top; never returned to Python or stored past
    the call.
    """
    from numba import types
    from numba.core import errors as nb_errors
    if not isinstance(arr, (types.Array, types.BaseTuple)):
        raise nb_errors.TypingError(f"borrowed: expected an array or a tuple, got {arr}")

    def codegen(context, builder, signature, args):
        return _borrow_value(context, builder, arr, args[0])

    return arr(arr), codegen


@njit(cache=True, inline="always")
def predict_kernel_call(addr, x, P, F, Qc, dt, buf):
    """The kernel at ``addr`` (a :class:`PredictWorkspace`'s ``kernel``) on ``x``, ``P``, ``F``,
    ``Qc`` and the workspace's ``buf``, with no size check: the caller has checked once that
    the arrays are C-contiguous float64 of the workspace's ``n`` (:func:`predict_sparse`
    checks on every call). For a compiled loop that binds the workspace's fields once."""
    _call_kernel(addr, x, P, F, Qc, dt, buf)


@njit(cache=True, inline="always")
def predict_sparse(x, P, F, Qc, dt, ws):
    """In place, ``x <- Phi x``, ``P <- Phi P Phi^T + dt/2 (Phi Qc Phi^T + Qc)``, symmetric.

    The math of :func:`inmotion.estimation.kalman._predict_kernel` (second-order
    ``Phi = I + F dt + (F dt)^2 / 2``, or ``I + F dt`` for a workspace of ``order`` 1;
    trapezoid ``Qd``, ``P`` symmetric, its diagonal floored at 0) by the kernel generated for
    ``ws``'s pattern (module docstring); no allocation. Also fills ``ws.PhiT`` (Phi's active
    rows, transposed, in its first ``na`` columns).

    Parameters
    ----------
    x : (n,) float64 error state, updated in place
    P : (n, n) float64, C-contiguous, symmetric covariance, updated in place
    F : (n, n) float64 continuous system matrix (rows outside ``ws``'s active rows ignored)
    Qc : (n, n) float64 continuous process-noise density (entries outside ``ws``'s Qc
        pattern ignored)
    dt : float, step [s]
    ws : :class:`PredictWorkspace` from :func:`make_workspace` for this ``n`` and pattern

    Raises ValueError when a size is not the workspace's ``n`` (the kernel reads and writes
    ``n`` and ``n x n`` entries through raw pointers).
    """
    n = ws.act.shape[0] + ws.inact.shape[0]
    if (x.shape[0] != n or P.shape[0] != n or P.shape[1] != n or F.shape[0] != n
            or F.shape[1] != n or Qc.shape[0] != n or Qc.shape[1] != n):
        raise ValueError("predict_sparse: x, P, F, Qc must be of the workspace's size n")
    _call_kernel(ws.kernel, x, P, F, Qc, dt, ws.buf)
