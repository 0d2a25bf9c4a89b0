"""One streaming closed-loop error-state Kalman filter: SINS (+ optional dead reckoner),
a :class:`~inmotion.estimation.layout.Layout`, the one shared error model, and measurement
plug-ins (:mod:`inmotion.estimation.measurements`).

Streaming, in the style of KF-GINS's ``addImuData`` / ``addGnssData``::

    f = ErrorStateFilter(init, layout, model, P0, [ForwardVelocity(...), Nhc(...)])
    f.add_measurement("sensor_velocity", t, [speed])    # queued until the IMU reaches t
    f.add_imu(t_rows, dtheta, dvel)                     # mechanization, predict, updates
    f.state(), f.sigma(), f.estimate()
    snap = f.snapshot(); ...; f.restore(snap)

A batch run is this streaming API fed from a bundle in chunks; there is no second code path.

What happens per IMU row and per filter epoch (one numba loop, :func:`_advance`):

1. the row, less the fed-back gyro drift and accelerometer bias estimates
   (:func:`~inmotion.estimation.nav_ops.compensated_row`), drives the SINS
   (:func:`inmotion.core._kernels.sins_step`) and, when the filter has a dead reckoner, the DR
   (:func:`inmotion.core._kernels.dr_step`) with the velocity sensor's distance and speed over
   the row. The DR integrates the SINS's compensated gyro rows, or, with
   ``dr_sees_gyro_drift=False`` (paper 000's printed F), the raw rows; a caller may hand the
   DR its own gyro rows (``dtheta_dr``: a second gyro triad, or a simulation study);
2. after ``step_rows`` rows (a filter epoch) ``F`` is built at the
   SINS state with the epoch's mean specific force
   (:func:`inmotion.estimation.error_model._fill_F`) and ``x, P`` are
   predicted over the epoch (second-order transition, trapezoid ``Q_d``) on F's nonzero rows
   only, by the kernel generated for F's sparsity pattern
   (:func:`inmotion.estimation.predict.predict_sparse`); the process noise
   is the model's ``G q G^T`` plus, with a DR, the random walk of the DR position driven by
   the velocity sensor's white noise (``dr_position_m2_s``, isotropic in E, N, U);
3. every queued measurement sample whose time is at or before the epoch's end is applied, in
   queue order (time, then the order of adding), by a gated sequential scalar Joseph update
   (:func:`inmotion.estimation.kalman.sequential_joseph`); its NIS is counted per kind (a
   measurement with its own test variances: "Test variances" below). A
   sample is therefore applied at the end of the first filter epoch that ends at or after its
   time (a latency below one epoch; none when samples fall on epoch ends, as in a batch run);
4. feedback: after every ``feedback_every``-th epoch that applied samples, the blocks of the
   feedback policy are fed back (closed loop: attitude, velocity, position of the SINS and
   DR, drift and bias into the IMU compensation; open loop: none; partial: a chosen subset)
   and zeroed; sensor states (``mount``, ``dk``, ``lever``) are estimated only;
5. every ``out_every``-th epoch an output row is written: the SINS corrected by the estimate
   not yet fed back, ``sigma``, the states (fed back plus current) and the ``phi`` covariance.

Local filters and the federated policy (paper 003 sec. 3.1-3.2). The engine holds ``L``
local filters on the one navigation system, all on the same layout: each measurement updates
one of them (or, ``shared``, every one with its noise scaled by that filter's
``r_scale = 1 / beta``, eq. 33-35), each is predicted with its own ``Q_c``. Which estimate is
the global one follows Table 1: two or more healthy *primary* locals are fused (eq. 36,
:func:`inmotion.estimation.federated.fuse_kernel`, over the leading ``n_common`` states), one
alone is taken as it is, with none the *fallback* local (the vehicle-constraint filter) is, and
with no fallback there is no estimate (the SINS runs free). Feedback applies the global
estimate (the feedback policy's blocks) to the navigation system and subtracts it from every
local filter, which keeps each local an estimate of the corrected system's error without
resetting its information (non-reset mode); with one local this is the ordinary closed loop
(the fed-back states become zero). A single filter is the case ``L = 1``.

Fault detection and isolation per measurement (``isolate``, eq. 40-42): a healthy
measurement whose NIS exceeds its gate is declared faulty and not applied; while isolated it
is still tested (on a copy) and returns after ``return_tests`` consecutive passing tests; a
local filter with an isolated measurement is unhealthy. Detections, returns and changes of the
global estimate's source are logged as events, the tested NIS values as a series.

Isolate and return (issue 15). Paper 003 (sec. 3.2.2, Table 1) masks a faulty channel's
measurements, lets the other sub-filter go on alone, and resumes the channel "after the
auxiliary device returns to normal"; it does not say against what the return is judged nor
what the masked sub-filter holds meanwhile. The masked sub-filter takes no update; the
non-reset feedback shifts every local by the same amount, so its *error* is frozen from the
isolation on (plus its own prediction), while its ``P`` grows by the prediction. A return
test of the channel's sample against that sub-filter alone (``return_conditioned=False``,
``fkf``'s ``return_test: masked``, its default before issue 15's helper h15retdef) latches: measured on paper 003's
fault-free drive at 0.05 (``benchmarks/fdi_calibration.py --runs 0 --detection-on-runs 20
--return-span off [--return-test masked]``, the reproduction's run 3, 1.65 s into the
window): the LDV isolated by one exceedance (8.03 > 4.46) while its sub-filter was young
(heading sigma 88'), and its statistic then stayed at 8-10 for the remaining 598 s (1198 of its 1200 tests
above the threshold) while the masked sub-filter's velocity error grew to up to 5 m/s at a
sigma of the same size (velocity NEES 8.0, attitude 9.2 over the isolation: a frozen draw, the error
moving with ``P``, so the statistic, the state part's NEES in the measurement's space, does
not move either). The masked sub-filter's ``P`` is not measurably too small: on the
reproduction's drives 0-2, 4, 5 (not latched) its NEES while isolated is that of the same
sub-filter while healthy (LDV horizontal velocity 3.60 / 3.39, 1.03 / 0.87, 1.85 / 2.31,
3.65 / 3.25, 2.92 / 2.64; attitude alike; ``benchmarks/fdi_return_probe.py``). Five of the
20 drives latch a channel so (exceedances per test with the
detection on 0.94, 0.95, 0.91 odometer, 1.00, 0.72 LDV): the cascade's 0.149 / 0.148
(10 drives) is mostly these, not a too-small ``P``; of the other 35 channel-drives 29 are
within 1e-2 of their detection-off rate.

With ``return_conditioned`` (``fkf``'s ``return_test: conditioned``, with ``return_span``
its default since helper h15retdef, below; paper 003's reproduction's fault experiment
names both) an isolated channel's test is of a *copy* of its masked sub-filter conditioned on the healthy primaries'
estimate of the common states (:func:`_condition_on_healthy`: eq. 36 over the other healthy
primaries, taken as a measurement of the copy's common block with its covariance; the
channel's own sensor states move by their correlation), so the test compares the sample
with what is known now, not with what the sub-filter knew at its isolation. The copy is
used for the test only: nothing is counted twice (the sub-filter itself stays non-reset;
the ``1 / beta`` sharing makes the locals' block-diagonal an upper bound of their joint
covariance, :mod:`inmotion.estimation.federated`, so the conditioned ``P`` bounds the copy's
error). After the return the channel is on probation: each sample is first tested against
the sub-filter itself (passed: applied, probation over); if that fails it is tested against
the conditioned copy as while isolated and, passed there, applied to the sub-filter itself
(an ordinary update of a filter whose ``P`` covers its grown error), failed there, the
channel is isolated again. Without it the returned channel was isolated again at once by
its frozen error (the reproduction's run 3: 950 events in 600 s, the test conditioned while
isolated only). Measured (20 drives, paper 003's reproduction's fault experiment, its
settings, Table 1 as printed, main filter every 10 s; exceedances per test with the
detection on against the same drives with it off, pooled and the interval over drives):

- at 0.05, LDV 5.07e-2 (over drives 4.75-5.39e-2; off 4.82e-2, 4.53-5.11e-2; masked
  0.138); odometer 7.37e-2 (3.99e-2-0.108; off 5.26e-2, 3.19-7.33e-2; masked 0.183). The
  over-drive intervals contain 0.05, but paired by drive the excess on - off is 2.5e-3
  (4e-4-4.6e-3) for the LDV and 2.1e-2 (1.9e-3-4.0e-2) for the odometer: four drives whose
  odometer exceeds 4-12 % with the detection off (its quantization phase, fixed over a
  cruise: ``inmotion.align.aided_kf``'s notes) double it with the detection on (0.077 /
  0.038, 0.116 / 0.043, 0.247 / 0.117, 0.242 / 0.113), the other 16 within 1e-2. Not the
  threshold's neglect of ``H P H^T`` (``aided_kf``'s residual-test notes: the test's
  ``C`` includes it; the statistic's exact law given ``C`` moves the rate by < 1e-3 pooled
  and by 0-3e-3 in an isolated or returned sub-filter's tests; ``benchmarks/
  fdi_state_probe.py``). Measured on those four drives (2, 5, 8, 12), paired by test: while
  the odometer is isolated or on probation its statistic exceeds 0.173, 0.240, 0.304, 0.256
  of the time against 0.044, 0.062, 0.141, 0.087 at the same tests with the detection off,
  at the same mean (2.43 / 2.53, 2.72 / 2.58, 2.98 / 3.03, 2.66 / 2.67): the isolations
  fall in stretches whose odometer error is large anyway (the forward innovation's spread
  there 1.45-1.66 ``sqrt(r)`` with the detection off, the model's about 1.0), and the
  isolation adds spread, not mean: the forward innovation is offset from the detection-off
  filter's by -0.19, -0.41, -0.22, +0.40 ``sqrt(r)`` (the lateral row's by 0.03-0.08), which
  lifts one level of the cruise's two-valued quantization error above the threshold (drive
  5's 95 % quantile 4.77 off, 6.72 on; threshold 4.65). The offset is mostly the odometer's
  scale factor: the sub-filter's ``dk`` with the detection on differs from the same drive's
  with it off by -0.48, -0.70, -0.84, +0.61 sigma while isolated (the offset's sign on each
  drive, 0.2-0.3 ``sqrt(r)`` of it at cruise), and about as much while healthy, where it
  does not show (the sub-filter's own velocity absorbed it); the conditioned copy takes its
  velocity from the LDV-based primaries and so exposes it. A threshold from the exact law
  would not remove it. Against the drawn scale factor (``fdi_state_probe.py --truth``) the
  detection-on ``dk`` is off by 0.72-1.59 sigma rms after the first minute on these drives
  (off: 0.40-1.07): the sub-filter's ``P`` does not cover it, so no conditioning of the
  copy on the healthy primaries (which hold no odometer ``dk``) makes the test honest; the
  copy's common states conditioned and its sensor states left (the covariance of that gain)
  measured 6.95e-2, within the Monte Carlo error of 7.37e-2. The cause is censoring: the
  rejected samples are those at the far level of the cruise's quantization, the applied
  ones then have a mean error the scale factor takes up, which lifts the far level further;
  a bare gate (an exceeding sample rejected, no isolation: ``benchmarks/
  fdi_censoring.patch``) takes drives 8 and 12 from 0.117 / 0.113 to 0.416 / 0.415 with
  ``dk`` 5 sigma off. Any test that drops the odometer's exceeding samples at 0.05 has it;
  isolate-and-return, which drops whole isolations of either level, less so; the return
  span (below) gives an isolation's intervals back at its return and removes it;
- at 1e-3, unchanged by the return test on these 20 drives (odometer 1.63e-3, LDV 1.54e-3
  with the detection on, 1.50e-3 / 1.58e-3 off);
- the paper's four faults at 0.05 detected 17, 16, 20, 18 of 20 (masked 15, 16, 19, 18),
  each at its first sample (0.15 s); a miss is the channel already isolated by a false
  alarm at the onset; at 1e-3 20 of 20 each, 0.15 s, either way.

Not the default at first: with it everywhere, paper 003's reproduction (``inmotion reproduce 003``,
20 drives) kept every fault and false-alarm row at 1e-3 and moved Table 3's fkf heading
within Monte Carlo error (0.415' -> 0.416' mean), but its Strategy 2 (in-motion coarse, then
``fkf`` with multiplexing at 1e-3) went from a heading RMS of 0.93' to 1.43' (run 1: -0.57'
-> -4.22', run 18: 2.10' -> 3.21', run 19: -1.85' -> -1.93'): from that start both settings
isolate and return channels many times at 1e-3 (a young sub-filter's ``H P H^T``, which the
threshold's model neglects). Measured (``benchmarks/fdi_strategy2_probe.py --compare``):
with the detection off the same row is 1.34'; paired by run the squared heading error
conditioned - off is +0.27 (standard error 0.75) arcmin^2, masked - off -0.92 (0.69),
conditioned - masked +1.19 (0.91), so 20 runs do not resolve it; three quarters of it is
run 1, where ``masked`` isolates the fault-free LDV at 116.65 s for good (529 s of 600 in
all; the latch above) and the heading is the odometer's alone (-0.57'), while ``conditioned``
returns it each time (27 s in all) and gives the fused filter's -4.22' (detection off
-3.30'); without run 1: 0.95' masked, 1.11' conditioned, 1.14' off. The probation's forced
updates are not it (their ``R`` raised so that the statistic sits at the threshold: 1.44').
The remaining reason it was not the default: the odometer's excess at 0.05 (above), which
the return span (below) removes; both are ``fkf``'s defaults since ("Defaults" below).

Return span (issue 15, ``return_span``; ``fkf``'s ``return_span``, on by default since helper
h15retdef; on in
paper 003's reproduction's fault experiment, ``reproductions.paper003.FDI_RETURN_SPAN``).
The odometer's censoring above drops the far level of the cruise's quantization; but the
pulses keep counting while the channel is isolated, and the distance over the whole
isolation has the quantization of its two ends only (a pulse at most), whichever levels its
intervals had. So at a return the intervals whose samples were not applied since the last
one that was (the isolation's, and the returning one) are joined into one interval, the
span, and its displacement increment is applied instead of nothing (the returning sample
was not applied before): every interval's distance then enters the sub-filter once, either
in its own sample or in a span, and the applied set is no longer selected by level. The
row accumulator's sums are additive (``Delta P``, ``Delta D``, ``Delta W``, ``Delta
theta_nb``, ``F``, ``T``), so the span is kept in ``macc``'s columns after the interval's
(:data:`_SPAN`; ``macc`` is wider only with the option, so the compiled loop's types do not
change) by adding each unapplied interval's sums, and filled by the measurement's own fill
with ``T`` the span's length. Its rows are paper 003's displacement increment (its ref. 38
for the measurement, eq. 26 for the state model) over the span: ``z = C_n^b (Delta P -
Delta D)``, whose SINS side ``int dv dt`` is the position-error difference ``dp(t_b) -
dp(t_a)`` over the span, expanded about the end ``t_b`` as the interval's rows already are,
``T dv(t_b) - T^2 / 2 ([f_n x] phi + C_b^n nabla)``
(:func:`inmotion.estimation.measurements._fill_displacement`); left out are the gyro drift's
``T^3 / 6`` term, the masked sub-filter's process noise over the span (``q T^3 / 3``: 0.9
mm at 10 s with paper 003's VRW) and the specific force's change within the span times the
attitude error (about ``phi df T^2 / 8``: 2 mm at 10 s, 1 arcmin and 0.5 m/s^2), so spans
longer than ``return_span_max_s`` (``fkf``: 10 s) are not applied. Each row's variance is
the fill's for ``T`` times ``T_int / T`` (``T_int`` the returning interval's length): linear
in the span's length, as the white parts grow (the sensor's noise, the constraint
violation's interval means, ``aided_kf``'s white equivalent); the odometer's quantization,
which does not grow, is then over-counted by the number of intervals (conservative). A
feedback within a span shifts the SINS: :func:`_span_feedback` adds ``-dv T_el`` to the
span's ``Delta P`` and ``phi x`` the sums so far to ``Delta D``, ``Delta W``, ``F`` (``C_b^n
<- (I + [phi x]) C_b^n``), so that the span reads a SINS corrected from its start (a
feedback within an ordinary interval is not corrected; paper 003's feedback falls on the
sample epochs). The span is tested as the isolated samples are (on the conditioned copy
with ``return_conditioned``) and applied to the sub-filter itself only if it passes: a fault
that ended during the isolation is in the span (``tests/test_fdi_return_span.py``: a 0.1
m/s odometer offset over 3 s, its span rejected, the scale factor unmoved at the return).
An interval whose sample has no rows (a gap in the sensor's distance) voids the span.

Measured (``benchmarks/fdi_calibration.py --runs 0 --detection-on-runs 20
[--return-span off]``, 61 s each; the paper's setting as above, ``conditioned``): at 0.05 the
odometer's exceedances per test with the detection on 5.12e-2 (over drives 3.10-7.14e-2)
against 7.37e-2 without the span and 5.26e-2 with the detection off; paired by drive on -
off -1.4e-3 (-2.9e-3-1.1e-4; without the span 2.1e-2, 1.9e-3-4.0e-2); the four drives
2, 5, 8, 12 on / off 0.038 / 0.038, 0.046 / 0.043, 0.109 / 0.117, 0.107 / 0.113 (without
the span 0.077, 0.116, 0.247, 0.242). LDV 5.00e-2 (4.66-5.33e-2), paired +1.8e-3
(-8e-5-3.7e-3; without 2.5e-3). At 1e-3 odometer 1.46e-3, LDV 1.58e-3 (without 1.63e-3,
1.54e-3; off 1.50e-3, 1.58e-3). Faults at 0.05 detected 20, 16, 19, 18 of 20 (without 17,
16, 20, 18; a miss is still a channel isolated at the onset), at 1e-3 20 each, 0.15 s.
Final heading RMS of the faulted drive at 0.05 1.001' (without 1.207'; paired squared
difference -0.46 arcmin^2, standard error 0.25), fault-free drive 0.887' (0.827'; +0.10,
0.11), at 1e-3 1.147' / 0.816' (1.143' / 0.827'). The odometer's scale factor against the
drawn one (``benchmarks/fdi_return_span.py``, after the first minute, ``(dk - dk_true) /
sigma`` rms, detection off / on / on with the span): drives 2, 5, 8, 12
0.40 / 0.72 / 0.38, 0.83 / 1.59 / 1.07, 0.54 / 1.21 / 0.69, 1.07 / 1.36 / 0.93, drives 0, 1
(no excess) 0.57 / 0.63 / 0.55, 0.65 / 0.61 / 0.91 (mean 0.68 / 1.02 / 0.76): the scale
factor's error back to about the detection-off filter's, within its sigma; 9-119 spans
applied per drive, 0-3 rejected, the longest 3.5 s. ``fkf``'s NEES
(``benchmarks/nees_methods.py 20 fkf``: 2.44 under the defaults, band 2.02-4.16) with
``return_test: conditioned`` 2.44 and with the span too 2.44, run for run (at 1e-3 on the
85 s drive a span is rare; the 30-times sensors' overconfident case 15.27, 15.48, 15.60);
at 0.05 (``with_length_knobs.py`` setting ``false_alarm_rate``) 2.44 conditioned, 2.37 with
the span (band 2.02-4.16). Strategy 2 (``benchmarks/fdi_strategy2_probe.py --compare``,
its ``fkf`` at 1e-3): the reproduction's ``fkf`` there had the defaults then (``masked``, no span) and was unchanged
(0.931'); with the span, ``masked`` 1.095' (paired squared difference +0.33 arcmin^2,
standard error 0.34), ``conditioned`` 1.268' against 1.434' (-0.45, 0.48): not resolved by
20 runs (run 18, from a heading 150' off, +2.10' -> +3.34' ``masked``: the odometer isolated
3 s instead of 8 s in the young filter, as ``conditioned`` does).

Defaults (issue 15, helper h15retdef): ``fkf``'s ``return_test: conditioned`` and
``return_span: true`` (the engine's own ``return_conditioned`` / ``return_span`` stay False).
Measured under ``fkf``'s default settings otherwise (``benchmarks/fdi_calibration.py --runs 0
--detection-on-runs 20 --fkf-defaults --return-test masked|conditioned --return-span
off|on``: paper 003's fault experiment's 20 drive pairs, the library's rows and noise, main
filter every 1 s, the isolated sub-filter fused), exceedances per test of the fault-free drive
with the detection on minus the same drive's with it off, paired by drive (t-interval): at
0.05 odometer +6.3e-4 (-5.8e-4 to 1.8e-3) against ``masked``'s +1.9e-2 (1.3e-3 to 3.7e-2:
no drive latches under these settings, but the censoring above doubles four drives'
odometer rate), LDV +1.1e-3 (-1.7e-4 to 2.4e-3) against +2.2e-3 (5.9e-4 to 3.8e-3); at 1e-3
0 and 0 against +1.3e-4 (-6.6e-5 to 3.2e-4) and 0. The paper's four faults at 0.05 detected
20, 17, 19, 18 of 20 (``masked`` 17, 15, 20, 18), at 1e-3 20 each either way; the odometer
step bias (``--det-on-runs 10 --biases 0.005,0.01,0.02``) identical run for run. Final
heading RMS at 0.05 faulted drive 1.080' (``masked`` 1.103'), fault-free 0.609' (0.645'), at
1e-3 1.030' / 0.638' (1.033' / 0.636'). NEES (``benchmarks/with_length_knobs.py 0 4
'{"return_test": ..., "return_span": ..., ["false_alarm_rate": 0.05]}'
benchmarks/nees_methods.py 20 fkf``, band 2.02-4.16): at 1e-3 2.44 (``masked`` 2.45), at
0.05 2.25 (2.44; paired -0.19, standard error 0.07); conservative 1.62 either way; the
30-times sensors' overconfident case 15.62 / 14.96 (15.27 / 14.76). Strategy 2 with
``fkf``'s defaults (``benchmarks/fdi_strategy2_probe.py --fkf-defaults``): heading RMS
0.714' (``masked`` 0.723', detection off 0.712'; paired squared difference -0.01, standard
error 0.04 arcmin^2). The reproduction's Strategy 2 row (``PAPER_FKF``, main filter every
10 s, Table 1 as printed), which takes the defaults: 1.268' against ``masked``'s 0.931'
(paired +0.74, standard error 0.51 arcmin^2; detection off 1.34'), of which run 1 is 7.98
(``masked`` latching out the fault-free LDV for 529 s: -0.57', conditioned + span -2.88')
and run 18 6.74 (+2.10' -> +3.34', above); without run 1 0.946' / 1.120'.

Variants tried before (issue 15, 10 drives, at 0.05 the exceedances per test odometer /
LDV, the four faults detected of 10, ``tests/test_paper003_filters.py``'s faulted drive's
final heading (limit 11.9'), ``tests/test_consistency_nees.py``'s fkf NEES; before: 0.149 /
0.148; 7, 6, 10, 9; 2.8'; 5.21): the isolated sub-filter's ``dv``, ``dp`` replaced at each
test by the healthy channel's with the share ``P_g / beta_l`` and its other states moved by
their regression (the sub-filter itself, not a copy): 0.063 / 0.049; 8, 7, 10, 9; 13.3'
(fails: the regression walks the masked sub-filter's heading during a real fault); without
the regression 0.157 / 0.145; the test on a regression-conditioned copy and the sub-filter
re-based at its return: 0.130 / 0.106; every common state re-based: NEES 5.32, and with the
healthy primaries' blocks multiplied by ``1 + beta_l`` at each return 0.28 / 0.28; the
healthy estimate fed to the isolated sub-filter as a measurement: 0.59 / 0.66, NEES 7.0.

While a channel is isolated, the global estimate (``fuse_isolated``, ``fkf``'s
``isolated_in_fusion``, default there) fuses every primary, the masked sub-filter's
prediction too, whenever one primary is healthy (Table 1's output filter is "main filter" in
the sub-filter modes; which sub-filters take measurements, the logged ``mode``, is Table 1's
unchanged). The masked sub-filter has none of the faulty channel's samples from the
detecting one on (a step fault is rejected at its first sample), and what it knew before is
still its own, independent information (eq. 36's premise): its covariance grows by its
prediction. Without it the output and the feedback jump to the one healthy channel's
estimate at each false isolation, and the run keeps the jump: ``tests/
test_consistency_nees.py``'s run 2 (two false isolations at 1e-3) ends at NEES 11.5 with
Table 1 as printed, 5.4 with the fusion (5.96 with the detection off); the 6 runs' mean
5.21 -> 4.19, 20 runs (seeds 100-119, ``benchmarks/nees_methods.py 20 fkf``) 3.30 -> 3.00
(band 2.02-4.16). Its limit: the masked sub-filter's velocity and position go without their
sensor (its error frozen and its covariance growing, above), and a false isolation selects
a sub-filter whose error is large; over a 1 s isolation at 1e-3 that costs less than the
switch, at 0.05 in the paper's setting (``isolated_in_fusion:
false`` in :mod:`inmotion.reproductions.paper003`, Table 1 as printed) it is not measured
to help: LDV faults detected 7 and 6 of 10 with it against 10 and 9 without.

Invariant velocity error (issue 15, session 23; ``invariant_velocity``). A common turn of the
whole solution about the vertical (attitude, velocity, and position about any point) changes
nothing the velocity sensors, the vehicle constraints, a zero-velocity or a height update
measure (the body-frame velocity ``C_n^b v^n`` is invariant under it; only the Earth rate,
~15 deg/h, tells it, which gyros of 100 deg/h and worse cannot). In the filter's error state
that direction is ``phi = psi u``, ``dv = -psi u x v`` (``u`` up, ``v`` the estimate): it
moves with the estimate. Each feedback moves the linearization point and so the direction,
and the covariance, which held no information along the old one, gains some along the new
one: the EKF's false observability (Huang, Mourikis, Roumeliotis 2010 for SLAM; for the INS
Barrau and Bonnabel 2017, the right-invariant EKF, whose error does not move with the
estimate). Measured on a simulated city drive with a 300 deg/h gyro (plus 150 deg/h
Gauss-Markov) and nhc-kf matched to it (``benchmarks/nees_invariant.py``, 5 runs): the heading
sigma grew to 98-205 arcmin by 60 s, then *fell* to 47-94 arcmin by 120 s (the turns) while
the errors grew to up to 10 deg, and to up to 41 deg by the end (heading NEES 65.7); started turned by 10 deg
with its velocity (no measurement here sees that), the sigma fell from 436 to 44-363 arcmin
at the first 90 deg turn and to 58-116 by 120 s, the error staying 9-11 deg.

The cure used here (on with ``invariant_velocity``): the velocity error ``dv' = dv + phi x v``
(right-invariant, as Barrau and Bonnabel's), in which that direction is ``phi = psi u, dv' =
0`` wherever the estimate is. The predict needs nothing: ``F`` with the epoch's specific force
is the invariant error's ``dv'_dot = -[g x] phi + C_b^n dnabla + [v x] C_b^n deps`` carried
along the predicted trajectory (``d/dt(phi x v) = phi_dot x v + phi x (f + g)`` and ``[f x]
phi + phi x f = 0``), and an update's ``H`` is the same in either coordinates at the
predicted state. The feedback differs in two ways (:func:`_invariant_velocity`,
:func:`_invariant_velocity_reset`): the velocity is corrected by the invariant retraction,
``v <- R(phi) (v - dv - phi x v)`` with ``R(phi)`` the rotation the attitude feedback applies
(a heading correction turns the velocity with it; ``v - dv - phi x dv`` to second order),
and the covariance is carried across the change ``dV`` of the velocity holding ``P'`` (the
invariant error's covariance): ``P <- J P J^T``, ``J = I + E``, ``E[dv, phi] = [dV x]``, the
estimate not fed back alike (9 n flops a feedback). Position is left in its own coordinates
(a common turn's position part lies in the span of the horizontal position errors, which
none of these measurements sees either). The covariance transform alone (with the standard
``v - dv``) was tried first: right on the simulated drive (NEES 3.6), but on the real EMS
log with an assumed 1000 deg/h spec it ran away to NaN by 300 s (a large ``dV`` times a
large heading variance fed the next correction); with the retraction it stays bounded.
Measured with both (same runs): heading NEES 0.83 at 300 deg/h (the sigma grows to 18-22
deg, which the errors, up to 35 deg, need), 0.61 at 100 deg/h (7.19 without); the 10 deg
start keeps 435-441 arcmin from 20 s to the end. Real logs, nhc-kf from the reference: PSINS
MEMS (a mounting 4.8 deg off that nobody gave) horizontal 210 -> 38 m, heading -371 -> -183
arcmin (at the 300 arcmin floor); comma2k19 heading -105 -> -93 arcmin, horizontal 37 -> 163
m at a 110 m sigma. On by default in ``nhc-kf``, ``od-kf`` and ``ldv-kf``
(``invariant_velocity_error``; od-kf on the same drive: heading NEES 3.12 -> 1.24) and, since
session 24, in the velocity-aided filters of papers 000 and 002 (``od-velocity-kf`` 5.23 ->
0.80, ``sins-dr`` 6.25 -> 0.43, ``dr-kf`` 2.02 -> 2.04, the same drive and runs). Their DR
needs nothing of its own: it has no velocity state (its velocity is the speed along its
attitude, which the common turn turns with the SINS's), its attitude block ``phi_D`` takes
the turn as ``phi`` does, and its position, as the SINS's, lies in the span of the common
translations that only the difference of the two positions sees. Off in
``fkf`` (with it the bank's conditioned return test, ``tests/test_fdi_cascade.py``, failed: its
LDV statistic's mean after the fault over seeds 300-311 3.12 against 2.38 standard, model
1.50, higher on 8 of 12 seeds: not resolved; :class:`inmotion.align.aided_kf.FkfConfig`), in a two-stage method's fine stage (from the
PSINS MEMS log's unresolved coarse heading fine-mux ended 3.5 times its sigma off in level, 0.6
standard). The smoother undoes the reset as it undoes the shift of the standard
feedback (:func:`~inmotion.estimation.smoother.rts_backward`: the smoothed ``x``, ``P``
through ``J^-1``, ``dV`` read from the recorded feedback, which then holds the velocity change
made).

Test variances (issue 15, :attr:`~inmotion.estimation.measurements.Measurement.test_variance`).
A measurement may give its rows a variance for the residual test apart from the update's:
its fill writes them at ``r[dof:dof + m]`` (0: the row's ``r``; the engine hands ``r`` with
``2 dof`` entries, zeroed). Its samples then go through :func:`_apply`: the statistic (the
gate, the NIS log and sums, the isolation and return decisions) is ``nu^T (H P H^T +
R_test)^-1 nu`` by a batch solve of the ``m <= dof`` rows (:func:`_test_statistic`), and an
accepted sample is applied by the same ungated
:func:`~inmotion.estimation.kalman.sequential_joseph` with ``R`` as without it, so the
filter's estimates are bit for bit those of the same measurement without test variances
whenever the same samples are accepted (always with the detection off; only the statistic
changes: ``tests/test_test_variance.py``). Other measurements pay nothing. The use: a row
whose ``R`` is inflated for an error that persists over intervals (so that the gain is
honest) while a single interval's residual has its marginal variance: ``fkf`` / ``od-kf`` /
``ldv-kf``'s length row under ``second_order_length``
(:class:`inmotion.align.aided_kf._LengthIncrement`).

Test covariance (issue 15, ``test_covariance``). A filter whose rows' ``R`` is inflated for
the gain (above) or whose locals carry the federated ``1 / beta`` on their prior and process
noise (eq. 33-35) keeps a ``P`` that over-bounds its error, so ``H P H^T`` over-states the
residual's spread and the test is deflated (fkf's false-alarm rate at a set 0.05 was 4.2e-2,
the first minute's statistic a third of its model's). With ``test_covariance`` each local
filter carries a second covariance ``Pa``, the covariance of the error its own gains leave
when the rows' noise is ``R_test`` (the covariance analysis of a suboptimal filter: Gelb,
*Applied Optimal Estimation*, 1974, sec. 7.2; Maybeck, *Stochastic Models, Estimation and
Control* 1, 1979, sec. 6.8):

* it starts at :class:`LocalFilter`'s ``P0_test`` and is predicted with the same ``Phi`` and
  ``Qc_test`` (the true prior and the IMU's own noise where the local's carry ``1 / beta``):
  ``Pa <- Phi Pa Phi^T + Qd_test``;
* every update applied to ``P`` is applied to ``Pa`` with ``P``'s gain ``k = P h^T / (h P
  h^T + r_i)`` and the row's test variance (a shared row's unscaled one), in the Joseph form
  of a given gain, ``Pa <- (I - k h) Pa (I - k h)^T + r_test,i k k^T``
  (:func:`~inmotion.estimation.kalman.sequential_joseph_pair`); the feedback subtracts the
  global estimate from each local and leaves its error, so ``Pa`` too;
* the statistic of the local's own test (the gate, NIS log and sums, isolation) is ``nu^T (H
  Pa H^T + R_test)^-1 nu``. The tests of an isolated channel on a copy (its return, the
  conditioned copy, the return span) keep ``P``: it bounds ``Pa`` from above (``R >=
  R_test``, ``1 / beta >= 1``), so those tests are conservative, a return later, never
  earlier.

``P``, the estimates and the outputs are untouched: with the detection off the filter is bit
for bit the one without (``tests/test_test_covariance.py``). Cost: a second predict and a
second rank-one update per row (fkf's 10-minute drive 0.107 -> 0.125 s CPU). The default of
``fkf``, ``od-kf`` and ``ldv-kf`` (:func:`inmotion.align.aided_kf.test_covariance_on`), where the length row's test variance is
then the sensor's alone: the row's second-order error persists over the intervals and the
along-track states absorb it (measured: the statistic's first-minute windows with its
single-interval variance 0.60 / 0.63 of 1.50, with the sensor's 1.42 / 1.19), see
``benchmarks/fdi_calibration.py`` for the false-alarm rates.

Row accumulators: a measurement over an interval (paper 003's displacement increment) has an
accumulator function called on every IMU row with the row's data (e.g. the odometer's
distance), reset when its sample is applied; the engine then also forms the body rate with
respect to n per row (``aux[7:10]``: its epoch mean).

The whole filter state lives in the arrays of :class:`_State`, so :meth:`snapshot` /
:meth:`restore` are copies, and a run split anywhere continues bit-identically.

Cost (issue 13, ``benchmarks/bench_engine.py``: 22 states, a predict every 100 Hz IMU row,
forward velocity and NHC at 10 Hz, output at 1 Hz; CPU time, best of 2-3 runs on a 2-core
machine at load 7-9): 0.47-0.50 s per hour of data with the predict kernel generated for F's
pattern, 0.81-0.84 s with the former BLAS predict, measured side by side (KF-GINS 3.5 s).
Measured by switching parts off (load ~15, so every figure is inflated alike): the predict
0.10 s (~0.29 us a row), ``_fill_F`` 0.025 s, mechanization 0.07 s, the rest of the per-row
path 0.065 s, the 10 Hz sample epochs (then a call of a separate epoch-end function, two
fills, five scalar Joseph rows, mode, feedback, the 1 Hz output; ~5 us each) 0.2 s.
Switching parts off again at load ~20 showed the five scalar updates to be nearly all of a
sample epoch's own cost (0.12 s of 0.14 s per hour; the fills ~0, the feedback 0.013 s).
Since then (issue 13, this module and :func:`inmotion.estimation.kalman.sequential_joseph`):
every epoch runs the same inline code in :func:`_advance` (the predict, then the due
samples), the scalar update is the optimal-gain form ``P -= (P h^T)(P h^T)^T / s`` (a fifth
of the arithmetic of the expanded Joseph form, exactly symmetric), the mode is recomputed
only when a measurement can be isolated. Side by side, before and after, alternating
(best of 5, ``benchmarks/bench_engine.py``'s workload): 0.414-0.416 -> 0.338-0.344 s per
hour at load ~3.8, 0.436-0.454 -> 0.372-0.381 at load ~9; ``bench_engine.py --repeat 2
--no-cli`` at load ~9-12: engine 0.447 -> 0.391, ``sins-dr`` at 100 Hz 0.869 -> 0.733 s.
A call that passes the namedtuples ``S`` and ``C`` costs ~0.5 us whether inlined or not
(numba increfs and decrefs each of their ~50 arrays), so neither the per-row path nor a sample
epoch's common case makes one: :func:`_advance` binds their arrays once, predicts inline and
applies samples through calls that take arrays (the fill through its pointer,
``sequential_joseph``, :func:`_feed_back_arrays`); ``S`` and ``C`` are passed only on the
rare paths (:func:`_apply` for FDI, NIS logging and shared measurements, :func:`_global`
for a fused estimate, :func:`_epoch_outputs` for records and output rows).
Then (issue 13, side by side, best of 7 at load ~1: 0.360-0.377 -> 0.334-0.350 s per
hour, ratio ~0.92; ``bench_engine.py --repeat 5 --no-cli`` alternating at load ~1: 0.374,
0.356 -> 0.360, 0.341, ratio ~0.96): :meth:`ErrorStateFilter._call_advance` calls the compiled overload's
entry point with the types of ``S``, ``C`` and the measurement-function tuples computed
once per filter (a call of the dispatcher typed them every time: 1.6 -> 0.85 ms a call;
what remains is numba's unboxing of the 16 first-class functions); the predict kernel forms
``Phi_a Pt`` in a padded buffer and writes ``P`` row by row (bit-identical, 7 % less per
call); a smoother's forward pass calls :func:`_record_predict` with arrays instead of
``S``, ``C`` and copies ``P_k|k-1`` only at the epochs that record (the same arithmetic:
bit-identical records; the smoothed ``sins-dr`` hour's cost is elsewhere, 3.34-3.42 s
before and about the same after at load ~2).
Switching parts off (load 4-9, each figure the minimum of 5 runs, so only roughly
additive): of ~0.38 s per hour the predict ~0.18 s, the mechanization ~0.065 s, the 10 Hz
samples ~0.064 s, ``_fill_F`` ~0.03-0.06 s, the feedback ~0.008 s, and everything else (the
loop, Python, dispatch) ~0.057 s. A second predict kernel call per epoch (on a copy) adds
0.12-0.15 s per hour (load ~1.5-2.5), i.e. 0.34-0.41 us a call, as much as the kernel alone
in a tight loop (0.36 us): the predict's cost in the loop is its arithmetic (~950 4-wide
and ~550 scalar FMAs and their loads, ~3,600 instructions), not a cold cache.
Then (issue 13, reference counting): perf showed a third of the JIT time in two
one-instruction functions, numba's ``NRT_incref`` / ``NRT_decref`` (a ``lock inc`` /
``lock dec`` each); counted with gdb at them, the per-row path made 33 atomic operations
a row (20 around the predict call: the views ``X[l]``, ``P[l]``, ``Qc[l]``, ``F`` and the
workspace's six arrays bound by the inlined ``predict_sparse``; 6 in the mechanization, 6
in ``_fill_F``), an update epoch ~107 more (the fills' and the scalar updates' arguments),
an output epoch ~390 (the calls with ``S``, ``C``, ``O``). :func:`_advance` now binds
every array it uses, and ``S``, ``C``, ``O`` themselves, as borrowed views
(:func:`inmotion.estimation.predict.borrowed`: NULL meminfo, so each of those calls is a
test of NULL; the owners are alive for the call: ``S``, ``C``, ``O`` held by the caller,
the scratch arrays by a final :func:`_keep_alive`) and calls the predict kernel through its
address and buffer bound once (:func:`~inmotion.estimation.predict.predict_kernel_call`,
sizes checked once per call of :func:`_advance`); the feedback passes 3-tuples (no
``np.zeros(3)`` per feedback), the output epoch is a running counter (no integer modulo
per epoch). Atomic operations per row 37 -> 0.09 (gdb, 2,000 rows with samples);
results bit-identical (the equal-workload hour's ``x``, ``P``, SINS state equal).
Side by side (``benchmarks/profile_engine.py``, min of 5, alternating, load 10-15): the
whole filter 0.352-0.384 -> 0.304-0.320 s per hour, without the samples 0.296-0.314 ->
0.256-0.263. Parts at load ~13 (``profile_engine.py``): the predict kernel alone 0.12-0.13 s
per hour (at the arithmetic of its algorithm: ~950 4-wide and ~320 scalar FMAs, ~1000
cycles), mechanization 0.05, ``_fill_F`` 0.026, a bare loop of the three 0.19-0.21, the
filter without samples 0.24-0.26, with them 0.28-0.30 (the five scalar updates of an
update epoch 1.0 us, 0.037 s per hour, measured alone). ``bench_engine.py --repeat 3
--no-cli``, before and after alternating at load 3.6-4.7: equal workload 0.360, 0.389 ->
0.312, 0.308 s per hour; ``sins-dr`` at 100 Hz 0.776, 0.772 -> 0.678, 0.663 s.
Then (issue 13, the dead reckoner's cost inside the loop: ``sins-dr`` at 100 Hz cost ~0.28 s
per hour more than the equal workload): of it, the copy of all of ``Qc`` into ``Q`` every
row before adding the DR's position noise (``Q[:, :] = Qc``, 22 x 22: 0.058 s per hour
alone, load ~9), the larger predict kernel (0.65-0.72 against 0.33-0.37 us a call, ~0.12 s;
why: :mod:`~inmotion.estimation.predict`'s docstring), the DR's step
(:func:`inmotion.core._kernels.dr_step`, ~10 transcendental calls: 0.053 s per hour alone,
the SINS step 0.047) and the DR's rows of ``_fill_F`` and its position noise. ``Q`` is now
copied from ``Qc`` once per call of :func:`_advance` (one per local filter) and
:func:`_dr_position_noise` sets its three ``dp_D`` diagonal entries; the predict kernel no
longer sums the DR rows' columns into the SINS rows' entries (exact zeros). Results
bit-identical (the ``sins-dr`` hour's solution equal; the CLI's outputs equal byte for
byte). Side by side, alternating, min of 5 (load 5.4-6.7): ``sins-dr`` 1 h at 100 Hz
in-process 0.590, 0.624, 0.599, 0.610 -> 0.553, 0.543, 0.554, 0.496 s (-9 to -19 %); through the CLI (Parquet in, 1 Hz out, CPU time
of the command, min of 3, load 7.4-7.8) 1.86, 1.89 -> 1.77, 1.81 s.
Then (issue 13, the last few percent; perf with a symbol map of the JIT code, the equal
workload's hour: the predict kernel 56 % of the compiled code's samples, the SINS step with
its attitude update and libm's trigonometry 20 %, the scalar updates 10 %, ``_fill_F`` 5 %,
the rest of :func:`_advance` 5 %): the predict kernel forms each row of ``Phi_a`` right before
its row of ``Phi_a Pt`` (:mod:`~inmotion.estimation.predict`: forming all of ``Phi_a`` first
spilled most of its entries; 0.626 -> 0.564 us a call); :func:`inmotion.core._kernels.sins_step`
and :func:`inmotion.estimation.error_model._fill_F` are ``inline="always"`` (numba inlines
their code into this loop: no call boundary, so none of the reference-count calls their
array arguments cost at one). Bit-identical: the equal-workload hour's filter state and
``sins-dr``'s 1 h solution, plain and smoothed (101 arrays, ``np.array_equal`` against the
code before). Side by side (``engine_run`` of ``benchmarks/bench_engine.py``, best of 5 a
process, alternating): before -> kernel 0.478, 0.484 -> 0.438, 0.442 s per hour (load
3.5-4.7); kernel -> kernel + inlining 0.453, 0.448, 0.458 -> 0.423, 0.425, 0.421 (load ~5);
this machine's figures at load > 2 are ~1.8x those at load ~1 (two cores shared).
Numba's disk cache of :func:`_advance` is keyed on this file's contents only: a change to a
function it calls in another module (``sequential_joseph``, ``_fill_F``, ``sins_step``, the
fills' helpers) is not seen by a cached ``_advance``, which may have that function's old code
inlined; clear
``__pycache__/engine._advance*`` after such a change (a fresh install has no cache).
"""
from __future__ import annotations

import functools
import math
from collections import namedtuple

import numpy as np

from .. import _aot
from .._jit import njit
from ..core import _kernels as K
from ..core.mechanization import _state_vector
from ..core.solution import NavState
from . import error_model as em
from .federated import fuse_kernel
from .kalman import sequential_joseph, sequential_joseph_pair
from .layout import DP, DP_D, DV, EPS, KERNEL_BLOCKS, NABLA, PHI, PHI_D, Layout
from .measurements import (ACC_BAD, ACC_D, ACC_DP, ACC_FN, ACC_SIZE, ACC_T, ACC_W, ST_MOUNT,
                           ST_MOUNT_COV, STATE_PARAMS, AUX_FB, AUX_SIZE, AUX_T, AUX_WIB, AUX_WNB, Measurement,
                           accumulator_function, dispatcher, fill_function)
from .nav_ops import compensated_row, correct_nav, dcm_of_q, velocity_shear
from .predict import borrowed, make_workspace, predict_kernel_call

__all__ = ["ErrorStateFilter", "LocalFilter", "FEEDBACK_BLOCKS", "MAX_MEASUREMENTS",
           "EVENT_DETECTED", "EVENT_RETURNED", "EVENT_MODE", "MODE_FUSED", "MODE_NONE"]

#: measurement kinds one filter can hold (the compiled loop takes a fixed-length tuple)
MAX_MEASUREMENTS = 8
#: the blocks a feedback policy can feed back
FEEDBACK_BLOCKS = ("phi", "dv", "dp", "eps", "nabla", "phi_D", "dp_D")
_FB_INDEX = (PHI, DV, DP, EPS, NABLA, PHI_D, DP_D)
#: event kinds (:meth:`ErrorStateFilter.events`)
EVENT_DETECTED, EVENT_RETURNED, EVENT_MODE = 1, 2, 3
#: global-estimate sources besides a local filter's index
MODE_FUSED, MODE_NONE = -1, -2

# acc: epoch accumulators [rows, sum_dt, f_sum x3, w_sum x3, nb_sum x3]
_A_ROWS, _A_DT, _A_F, _A_W, _A_NB = 0, 1, 2, 5, 8
_A_SIZE = 11
# macc's columns after the interval's ACC_SIZE with ``return_span`` (issue 15): the span's
# accumulator (the intervals whose samples were not applied since the last one that was, and
# the feedback's corrections), then [spans applied, spans rejected by their test, longest
# span applied [s], the longest span allowed [s] (``return_span_max_s``)]; without it macc
# has the interval's ACC_SIZE columns only
_SPAN, _SPAN_OK, _SPAN_BAD, _SPAN_LONGEST, _SPAN_LIM = (ACC_SIZE, 2 * ACC_SIZE, 2 * ACC_SIZE + 1,
                                                        2 * ACC_SIZE + 2, 2 * ACC_SIZE + 3)
_SPAN_COLS = 2 * ACC_SIZE + 4
# ints: [epochs, update epochs, mode, events logged, NIS rows logged]
_I_EPOCHS, _I_UPDATES, _I_MODE, _I_EV, _I_NIS = 0, 1, 2, 3, 4

#: the filter's mutable state, arrays only (updated in place by the numba loop)
_State = namedtuple("_State", "xs ms xd md X P fed_back bias_g bias_a acc ints used rejected "
                              "nis_sum dof_sum t_end healthy normal_run tests exceed macc "
                              "ev nis_log phc ppred Pa")
#: the filter's constants
_Const = namedtuple("_Const", "offs offs9 Qc q_dr_m2_s inv_tau_dk inv_tau_b dr_eps grav_grad "
                              "with_dr step out_every fb_mask fb_states feedback_every C_bm l_b gates "
                              "params dofs local r_scale isolate return_tests primary fallback "
                              "n_common need_nb has_acc log_nis ws record fuse_isolated pstate "
                              "pstate_att o_mount3 return_conditioned test_r Qa invariant fuse_w")
#: the output buffers of one call
_Out = namedtuple("_Out", "t xs sigma states cov_phi mode local_x local_sig n rec_t rec_phi "
                          "rec_ppred rec_x rec_p rec_fed rec_xs rec_epoch nrec")


@fill_function
def _noop_fill(xs, xd, aux, acc, data, p, offs, z, H, r):
    return 0


@accumulator_function
def _noop_acc(a, xs, v_old, th_nb, dt, rd, p):
    return 0


# ----------------------------------------------------------------------------- the loop
@njit(cache=True)
def _local_ok(healthy, isolate, local, l):
    """Local filter ``l`` has no isolated measurement (arrays of ``S`` and ``C``)."""
    for j in range(isolate.shape[0]):
        if isolate[j] and local[j] == l and not healthy[j]:
            return False
    return True


@njit(cache=True)
def _local_healthy(S, C, l):
    return _local_ok(S.healthy, C.isolate, C.local, l)


@njit(cache=True)
def _mode_of(healthy, isolate, local, primary, fallback):
    """:func:`_mode` on the arrays it reads (a call with the namedtuples ``S``, ``C`` costs
    an incref and a decref of each of their ~50 arrays, 0.5 us)."""
    n_ok = 0
    last = -1
    for l in range(primary.shape[0]):
        if primary[l] and _local_ok(healthy, isolate, local, l):
            n_ok += 1
            last = l
    if n_ok >= 2:
        return MODE_FUSED
    if n_ok == 1:
        return last
    for l in range(fallback.shape[0]):
        if fallback[l]:
            return l
    return MODE_NONE


@njit(cache=True)
def _mode(S, C):
    """Source of the global estimate (paper 003 Table 1): MODE_FUSED over two or more
    healthy primaries, one healthy primary's index, else the fallback's, else MODE_NONE."""
    return _mode_of(S.healthy, C.isolate, C.local, C.primary, C.fallback)


@njit(cache=True)
def _global(S, C, mode, x_g, P_g):
    """The global estimate ``x_g`` (n,) and its covariance ``P_g`` (n, n) (NaN outside the
    fused leading block when fused; zero with MODE_NONE). With ``C.fuse_isolated`` the
    fusion takes every primary, the isolated ones' (masked, predicted) sub-filters too,
    whenever at least one primary is healthy (Table 1's sub-filter modes; module
    docstring)."""
    n = x_g.shape[0]
    nc = C.n_common
    use = np.zeros(S.X.shape[0], dtype=np.bool_)
    k = 0
    if mode == MODE_FUSED or (mode >= 0 and C.fuse_isolated and C.primary[mode]):
        for l in range(use.shape[0]):
            use[l] = C.primary[l] and (C.fuse_isolated or _local_healthy(S, C, l))
            if use[l]:
                k += 1
    if mode >= 0 and k < 2:
        x_g[:] = S.X[mode]
        P_g[:, :] = S.P[mode]
    elif k >= 2:
        xc = np.empty(nc)
        Pc = np.empty((nc, nc))
        fuse_kernel(S.X, S.P, use, nc, xc, Pc, C.fuse_w)
        x_g[:] = np.nan
        P_g[:, :] = np.nan
        x_g[:nc] = xc
        P_g[:nc, :nc] = Pc
    else:
        x_g[:] = 0.0
        P_g[:, :] = 0.0
        for i in range(n):
            P_g[i, i] = np.nan


@njit(cache=True, inline="always")
def _block3(x, o, on):
    """``x[o:o + 3]`` as a 3-tuple if ``on``, else zeros."""
    if on:
        return (x[o], x[o + 1], x[o + 2])
    return (0.0, 0.0, 0.0)


@njit(cache=True)
def _feed_back_arrays(xs, ms, xd, md, bias_g, bias_a, fed_back, X, offs, m, fb_states,
                      with_dr, x_g):
    """Apply the global estimate's fed-back blocks (the policy ``m``) to the navigation
    system and the IMU compensation, accumulate them, subtract them from every local filter
    (arrays only: a call with the namedtuples ``S``, ``C`` costs their reference counting)."""
    # the blocks as 3-tuples (no allocation, no reference counting, 10 Hz)
    phi = _block3(x_g, offs[PHI], m[PHI])
    dv = _block3(x_g, offs[DV], m[DV])
    dp = _block3(x_g, offs[DP], m[DP])
    correct_nav(xs, ms, phi, dv, dp, True)
    if with_dr and (m[PHI_D] or m[DP_D]):
        phiD = _block3(x_g, offs[PHI_D], m[PHI_D])
        dpD = _block3(x_g, offs[DP_D], m[DP_D])
        correct_nav(xd, md, phiD, dv, dpD, False)
    for i in range(3):
        if m[EPS] and offs[EPS] >= 0:
            bias_g[i] += x_g[offs[EPS] + i]
        if m[NABLA] and offs[NABLA] >= 0:
            bias_a[i] += x_g[offs[NABLA] + i]
    for p in range(x_g.shape[0]):
        if fb_states[p]:
            d = x_g[p]
            fed_back[p] += d
            for l in range(X.shape[0]):
                X[l, p] -= d


@njit(cache=True)
def _invariant_velocity(xs, x_g, o_phi, o_dv, v_old, v_new):
    """``v_old`` = the SINS velocity; ``v_new`` = the right-invariant retraction's corrected
    velocity ``R(phi) (v - dv - phi x v)`` (``R(phi)`` the rotation the attitude feedback
    applies, ``dv + phi x v`` the invariant velocity error's estimate): a heading correction
    turns the velocity with the attitude."""
    p0, p1, p2 = x_g[o_phi], x_g[o_phi + 1], x_g[o_phi + 2]
    for i in range(3):
        v_old[i] = xs[K.VE + i]
    w0 = v_old[0] - x_g[o_dv] - (p1 * v_old[2] - p2 * v_old[1])
    w1 = v_old[1] - x_g[o_dv + 1] - (p2 * v_old[0] - p0 * v_old[2])
    w2 = v_old[2] - x_g[o_dv + 2] - (p0 * v_old[1] - p1 * v_old[0])
    q = K.quat_from_rotvec((p0, p1, p2))
    r = K.qrotate(q, (w0, w1, w2))
    for i in range(3):
        v_new[i] = r[i]


@njit(cache=True)
def _invariant_velocity_reset(P, X, Pa, o_phi, o_dv, dv_fb):
    """Carry the covariance across a velocity correction in the right-invariant velocity
    error (``invariant_velocity``, module docstring "Invariant velocity error").

    The velocity error ``dv' = dv + phi x v`` (``v`` the estimate) does not depend on where
    the estimate is for a common rotation of attitude and velocity about the vertical: the
    direction the vehicle constraints and a speed cannot see stays unseen. With ``dv' = T(v)
    dv``, ``T(v) = [[I, 0], [-[v x], I]]`` on ``(phi, dv)``, keeping ``P'`` across the
    correction ``v -> v + dV`` gives, in the filter's ``(phi, dv)``,
    ``P <- J P J^T``, ``J = T(v + dV)^-1 T(v) = I + E``, ``E[dv, phi] = [dV x]``; the
    estimate not fed back moves alike, ``x_dv += dV x x_phi``. ``dV = -dv_fb`` (the fed-back
    velocity error is subtracted). Each local's ``P`` and, with test covariances, ``Pa``;
    the ``dv`` rows and columns are averaged with their transposes (exact symmetry)."""
    dV = (-dv_fb[0], -dv_fb[1], -dv_fb[2])
    none = np.zeros(0)
    for l in range(P.shape[0]):
        velocity_shear(P[l], X[l], o_phi, o_dv, dV, 1.0)
    for l in range(Pa.shape[0]):
        velocity_shear(Pa[l], none, o_phi, o_dv, dV, 1.0)


@njit(cache=True)
def _dr_position_noise(Q, Qc, o_dpD, lat, h, q_m2_s):
    """``Q``'s ``dp_D`` diagonal (rad, rad, m) set to ``Qc``'s plus the DR position random walk
    ``q_m2_s`` [m^2/s]; ``Q``'s other entries are left alone: the caller copies ``Qc`` into
    ``Q`` once (issue 13: a copy of all ``n^2`` entries every row cost more than the three
    entries that change with the latitude). Nothing without a DR block (``o_dpD < 0``)."""
    if o_dpD < 0:
        return
    r_m, r_n = K.radii(lat)
    Q[o_dpD, o_dpD] = Qc[o_dpD, o_dpD] + q_m2_s / (r_m + h) ** 2
    Q[o_dpD + 1, o_dpD + 1] = Qc[o_dpD + 1, o_dpD + 1] + q_m2_s / ((r_n + h) * math.cos(lat)) ** 2
    Q[o_dpD + 2, o_dpD + 2] = Qc[o_dpD + 2, o_dpD + 2] + q_m2_s


@njit(cache=True)
def _log_event(S, t, j, kind, value):
    i = S.ints[_I_EV]
    if i < S.ev.shape[0]:
        S.ev[i, 0] = t
        S.ev[i, 1] = j
        S.ev[i, 2] = kind
        S.ev[i, 3] = value
    S.ints[_I_EV] = i + 1


@njit(cache=True)
def _log_nis(S, t, j, nis):
    i = S.ints[_I_NIS]
    if i < S.nis_log.shape[0]:
        S.nis_log[i, 0] = t
        S.nis_log[i, 1] = j
        S.nis_log[i, 2] = nis
    S.ints[_I_NIS] = i + 1


@njit(cache=True)
def _write_output(S, C, O, t_now, x_g, P_g):
    i = O.n[0]
    if i >= O.t.shape[0]:
        return
    mode = S.ints[_I_MODE]
    _global(S, C, mode, x_g, P_g)
    O.t[i] = t_now
    xo = O.xs[i]
    xo[:] = S.xs
    offs = C.offs
    nonzero = False
    for a in range(3):
        if x_g[offs[PHI] + a] != 0.0 or x_g[offs[DV] + a] != 0.0 or x_g[offs[DP] + a] != 0.0:
            nonzero = True
    if nonzero:       # the SINS corrected by the estimate not yet fed back (open-loop output)
        correct_nav(xo, np.zeros(K.NMEM), x_g[offs[PHI]:offs[PHI] + 3],
                    x_g[offs[DV]:offs[DV] + 3], x_g[offs[DP]:offs[DP] + 3], True)
    n = x_g.shape[0]
    o_phi = offs[PHI]
    for p in range(n):
        O.sigma[i, p] = math.sqrt(max(P_g[p, p], 0.0)) if not math.isnan(P_g[p, p]) else np.nan
        O.states[i, p] = S.fed_back[p] + x_g[p]
    for a in range(3):
        for b in range(3):
            O.cov_phi[i, a, b] = P_g[o_phi + a, o_phi + b]
    O.mode[i] = mode
    if O.local_x.shape[1] > 0:
        for l in range(S.X.shape[0]):
            for p in range(n):
                O.local_x[i, l, p] = S.X[l, p]
                O.local_sig[i, l, p] = math.sqrt(max(S.P[l, p, p], 0.0))
    O.n[0] = i + 1


@njit(cache=True)
def _condition_on_healthy(S, C, l, Xc, Pc):
    """Condition a copy ``Xc``, ``Pc`` of local ``l`` (masked: a measurement of it isolated)
    on the healthy primaries' estimate of the common states (eq. 36 over the primaries other
    than ``l`` with no isolated measurement), taken as a measurement of ``Xc[:n_common]``
    with its covariance: ``K = Pc[:, c] (Pc[c, c] + P_h)^-1``, ``Xc += K (x_h - Xc[c])``,
    ``Pc -= K Pc[c, :]`` (the sensor states move by their correlation with the common ones).
    The locals' errors are taken as uncorrelated: the ``1 / beta`` sharing makes their
    block-diagonal an upper bound of the joint covariance (eq. 33-35,
    :mod:`inmotion.estimation.federated`), so the conditioned ``Pc`` bounds the error of
    ``Xc``. Returns False (copy untouched) when no other primary is healthy.

    With the sharing at the fusion (``C.fuse_w[l] < 1``, :mod:`inmotion.estimation.federated`)
    the bound is covariance intersection's: the copy's covariance is taken ``/ w_l`` and the
    healthy estimate's is the weighted fusion's; when no other primary is healthy the copy is
    conditioned on the fallback (the vehicle-constraint filter, which keeps its updates), its
    covariance ``/ (1 - w_l)`` (issue 15, session 25: at 0.05 on paper 003's drive both
    channels isolated at once were tested against their frozen masked copies and one drive of
    20 latched both for 270 s; with the fallback none does)."""
    nc = C.n_common
    L = S.X.shape[0]
    use = np.zeros(L, dtype=np.bool_)
    k = 0
    for i in range(L):
        use[i] = i != l and C.primary[i] and _local_healthy(S, C, i)
        if use[i]:
            k += 1
    xh = np.empty(nc)
    Ph = np.empty((nc, nc))
    if k == 0:
        fb = -1
        for i in range(L):
            if C.fallback[i]:
                fb = i
        if fb < 0 or C.fuse_w[l] >= 1.0:
            return False
        for a in range(nc):
            xh[a] = S.X[fb, a]
            for b in range(nc):
                Ph[a, b] = S.P[fb, a, b] / (1.0 - C.fuse_w[l])
    else:
        fuse_kernel(S.X, S.P, use, nc, xh, Ph, C.fuse_w)
    if C.fuse_w[l] != 1.0:        # sharing at the fusion: the copy's side of the bound
        for a in range(Pc.shape[0]):
            for b in range(Pc.shape[0]):
                Pc[a, b] /= C.fuse_w[l]
    Sm = np.ascontiguousarray(Pc[:nc, :nc]) + Ph
    Si = np.linalg.inv(0.5 * (Sm + Sm.T))
    PcT = np.ascontiguousarray(Pc[:, :nc])
    K = PcT @ Si
    d = xh - Xc[:nc]
    Xc += K @ d
    Pn = Pc - K @ PcT.T
    for a in range(Pc.shape[0]):
        for b in range(Pc.shape[0]):
            Pc[a, b] = 0.5 * (Pn[a, b] + Pn[b, a])
    return True


@njit(cache=True)
def _clear_rows(z, H, r, dof, split):
    """Zero the ``dof`` rows a fill writes: ``z``, ``H``, ``r`` and, with ``split``, the
    test's variances ``r[dof:2 dof]`` (:attr:`Measurement.test_variance`)."""
    for a in range(dof):
        z[a] = 0.0
        r[a] = 0.0
        if split:
            r[dof + a] = 0.0
        for b in range(H.shape[1]):
            H[a, b] = 0.0


@njit(cache=True)
def _test_statistic(x, P, z, H, rt, m):
    """The residual test's statistic ``nu^T (H P H^T + diag(rt))^-1 nu`` of the rows ``0:m``
    (``nu = z - H x``), by a batch solve (``m`` is a measurement's few rows)."""
    Hm = np.ascontiguousarray(H[:m])
    nu = z[:m] - Hm @ x
    S = Hm @ P @ Hm.T.copy()
    for i in range(m):
        S[i, i] += rt[i]
    return nu @ np.linalg.solve(S, nu)


@njit(cache=True)
def _update(x, P, Pa, z, H, rl, ra, m, xw, Pw):
    """The ungated update of ``x``, ``P`` with the rows ``0:m`` and noise ``rl``, and, with a
    test covariance (``Pa`` not empty), of ``Pa`` with the same gains and the noise ``ra``
    (:func:`~inmotion.estimation.kalman.sequential_joseph_pair`)."""
    if Pa.shape[0] == 0:
        sequential_joseph(x, P, z, H, rl, 0, m, 0.0, xw, Pw)
    else:
        sequential_joseph_pair(x, P, Pa, z, H, rl, ra, 0, m, Pw)


@njit(cache=True)
def _gated(x, P, z, H, rl, rt, m, gate, xw, Pw, split, Pa):
    """A gated update of ``x``, ``P`` with the rows ``0:m``: without ``split``
    :func:`~inmotion.estimation.kalman.sequential_joseph` with the noise ``rl`` (its
    statistic from the same variances); with it, the statistic with the test's variances
    ``rt`` (:func:`_test_statistic`), then, accepted (``gate`` 0 or the statistic at most
    ``gate``), the same ungated update with ``rl`` (bit for bit the update the rows get
    without ``split``). Returns ``(accepted, statistic)``."""
    if Pa.shape[0] > 0:                # the test on the test covariance (issue 15)
        nis = _test_statistic(x, Pa, z, H, rt, m)
        if gate > 0.0 and nis > gate:
            return False, nis
        _update(x, P, Pa, z, H, rl, rt, m, xw, Pw)
        return True, nis
    if not split:
        return sequential_joseph(x, P, z, H, rl, 0, m, gate, xw, Pw)
    nis = _test_statistic(x, P, z, H, rt, m)
    if gate > 0.0 and nis > gate:
        return False, nis
    sequential_joseph(x, P, z, H, rl, 0, m, 0.0, xw, Pw)
    return True, nis


@njit(cache=True)
def _noise_rows(r, d, m, scale, split):
    """``(rl, rt)``: the update's variances ``r[:m]`` and the test's (``r[d:d + m]``, 0 for
    "as ``r``", :attr:`Measurement.test_variance`; the same array without ``split``), both
    times ``scale``."""
    rl = r[:m] * scale
    rt = rl
    if split:
        rt = np.empty(m)
        for i in range(m):
            v = r[d + i]
            rt[i] = (v if v > 0.0 else r[i]) * scale
    return rl, rt


@njit(cache=True)
def _test_copy(S, C, l, z, H, rl, rt, m, gate, xw, Pw, split, conditioned):
    """The gated test of the rows on a copy of local ``l`` (an isolated channel's sample, a
    return span), conditioned on the healthy primaries first with ``conditioned``
    (:func:`_condition_on_healthy`); ``(accepted, statistic)``, the local itself unchanged."""
    Xc = S.X[l].copy()
    Pc = S.P[l].copy()
    if conditioned:
        _condition_on_healthy(S, C, l, Xc, Pc)
    return _gated(Xc, Pc, z, H, rl, rt, m, gate, xw, Pw, split, np.empty((0, 0)))


@njit(cache=True)
def _pa(S, l):
    """Local ``l``'s test covariance, or an empty array without one."""
    if S.Pa.shape[0] == 0:
        return np.empty((0, 0))
    return S.Pa[l]


@njit(cache=True)
def _apply(S, C, fills, j, l, z, H, r, m, xw, Pw, t_now, first):
    """Apply the filled rows of measurement ``j`` to local filter ``l`` (gate, FDI). A
    measurement with its own test variances (``C.test_r``, :attr:`Measurement.test_variance`:
    the fill wrote them at ``r[dof:dof + m]``, 0 for "as ``r``") is tested with them and
    updated with ``r`` (:func:`_gated`)."""
    split = C.test_r[j]
    rl, rt = _noise_rows(r, C.dofs[j], m, C.r_scale[l] if C.local[j] < 0 else 1.0, split)
    Pa = _pa(S, l)
    if Pa.shape[0] > 0 and C.local[j] < 0:     # the test covariance: the row's own noise
        rt = _noise_rows(r, C.dofs[j], m, 1.0, split)[1]
    if C.isolate[j]:
        S.tests[j] += 1
        if S.healthy[j] and S.normal_run[j] < 0:
            # on probation after a return (issue 15): the sub-filter's own test first (passed:
            # applied, probation over); failed, the sample is judged as while isolated, on the
            # conditioned copy, and if it passes there it is applied to the sub-filter itself
            # (its masked prediction's error is frozen since the isolation: the own test
            # would isolate the channel again on that alone)
            ok, nis = _gated(S.X[l], S.P[l], z, H, rl, rt, m, C.gates[j], xw, Pw, split,
                             Pa)
            if ok:
                S.normal_run[j] = 0
            else:
                ok, nis = _test_copy(S, C, l, z, H, rl, rt, m, C.gates[j], xw, Pw, split, True)
                if ok:
                    _update(S.X[l], S.P[l], Pa, z, H, rl, rt, m, xw, Pw)
            if not ok:
                S.exceed[j] += 1
                S.healthy[j] = False
                S.normal_run[j] = 0
                _log_event(S, t_now, j, EVENT_DETECTED, nis)
        elif S.healthy[j]:
            ok, nis = _gated(S.X[l], S.P[l], z, H, rl, rt, m, C.gates[j], xw, Pw, split,
                             Pa)
            if not ok:
                S.exceed[j] += 1
                S.healthy[j] = False
                S.normal_run[j] = 0
                _log_event(S, t_now, j, EVENT_DETECTED, nis)
        else:             # isolated: tested on a copy, never applied until it has returned
            ok, nis = _test_copy(S, C, l, z, H, rl, rt, m, C.gates[j], xw, Pw, split,
                                 C.return_conditioned)
            if ok:
                S.normal_run[j] += 1
                if S.normal_run[j] >= C.return_tests[j]:
                    S.healthy[j] = True
                    if C.return_conditioned:          # on probation
                        S.normal_run[j] = -1
                    _log_event(S, t_now, j, EVENT_RETURNED, nis)
            else:
                S.normal_run[j] = 0
            ok = False
    else:
        ok, nis = _gated(S.X[l], S.P[l], z, H, rl, rt, m, C.gates[j], xw, Pw, split,
                             Pa)
    if C.log_nis[j] and first:
        _log_nis(S, t_now, j, nis)
    if first:
        if ok:
            S.used[j] += 1
            S.nis_sum[j] += nis
            S.dof_sum[j] += m
        else:
            S.rejected[j] += 1


@njit(cache=True)
def _span_sample(S, C, fills, j, l, aux, data, t_now, was_isolated, used_before, z, H, r, xw,
                 Pw):
    """After measurement ``j``'s sample was judged (:func:`_apply`) with ``return_span``
    (issue 15, module docstring "Return span"): the interval joins the span (``macc[j]``'s
    span columns) when its sample was not applied, the span closes when one was; at a return
    the span (the isolation's intervals and this one) is filled as one long interval, tested
    as the isolated channel's samples are (on the conditioned copy with ``return_conditioned``)
    and, passed, applied to the local filter itself (then it stands for this sample)."""
    mj = S.macc[j]
    cur = mj[:ACC_SIZE]
    if was_isolated and S.healthy[j]:
        T_int = cur[ACC_T]
        span = np.empty(ACC_SIZE)
        for i in range(ACC_SIZE):
            span[i] = mj[_SPAN + i] + cur[i]
        span[ACC_BAD] = max(mj[_SPAN + ACC_BAD], cur[ACC_BAD])
        T_sp = span[ACC_T]
        if T_int > 0.0 and T_sp > 1.5 * T_int and T_sp <= mj[_SPAN_LIM]:
            dof = C.dofs[j]
            split = C.test_r[j]
            _clear_rows(z, H, r, dof, split)
            m = fills[j](S.xs, S.xd, aux, span, data, C.params[j], C.offs, z, H, r)
            if m > 0:
                # each row's variance grows linearly over the span (the white parts: the
                # sensor's noise, the constraint violation's interval means), not with T^2
                # as the fill's rows take it for one interval (module docstring); the test's
                # own variances (:func:`_apply`) likewise
                rl, rt = _noise_rows(r, dof, m, T_int / T_sp, split)
                ok, nis = _test_copy(S, C, l, z, H, rl, rt, m, C.gates[j], xw, Pw, split,
                                     C.return_conditioned)
                if ok:
                    _update(S.X[l], S.P[l], _pa(S, l), z, H, rl, rt, m, xw, Pw)
                    mj[_SPAN_OK] += 1.0
                    mj[_SPAN_LONGEST] = max(mj[_SPAN_LONGEST], T_sp)
                else:
                    mj[_SPAN_BAD] += 1.0
        for i in range(ACC_SIZE):
            mj[_SPAN + i] = 0.0
    elif S.used[j] > used_before:            # applied: the span closes
        for i in range(ACC_SIZE):
            mj[_SPAN + i] = 0.0
    else:                                    # not applied: the interval joins the span
        for i in range(ACC_SIZE):
            if i == ACC_BAD:
                mj[_SPAN + i] = max(mj[_SPAN + i], cur[i])
            else:
                mj[_SPAN + i] += cur[i]


@njit(cache=True)
def _span_feedback(macc, isolate, has_acc, x_g, offs, m):
    """The feedback's corrections of the open spans (issue 15): the span's SINS displacement
    and sensor sums become those of a SINS corrected by ``x_g`` (the fed-back blocks ``m``)
    from the span's start, ``Delta P -= dv T_el`` (``T_el`` the span's time so far, with the
    current interval's) and ``Delta D``, ``Delta W``, ``F`` (summed with the SINS attitude,
    corrected ``C_b^n <- (I + [phi x]) C_b^n``) ``+= phi x`` their sums so far; kept in the
    span's columns (its sums are additive), so that an interval whose sample is applied
    drops them with the span."""
    phi = _block3(x_g, offs[PHI], m[PHI])
    dv = _block3(x_g, offs[DV], m[DV])
    for j in range(isolate.shape[0]):
        if not (isolate[j] and has_acc[j]):
            continue
        mj = macc[j]
        T_el = mj[_SPAN + ACC_T] + mj[ACC_T]
        if T_el <= 0.0:
            continue
        for i in range(3):
            mj[_SPAN + ACC_DP + i] -= dv[i] * T_el
        for o in (ACC_D, ACC_W, ACC_FN):
            s0 = mj[_SPAN + o] + mj[o]
            s1 = mj[_SPAN + o + 1] + mj[o + 1]
            s2 = mj[_SPAN + o + 2] + mj[o + 2]
            mj[_SPAN + o] += phi[1] * s2 - phi[2] * s1
            mj[_SPAN + o + 1] += phi[2] * s0 - phi[0] * s2
            mj[_SPAN + o + 2] += phi[0] * s1 - phi[1] * s0


@njit(cache=True)
def _state_to_params(p, s, X, P, l, o_a, o_v, o_m):
    """Write the local filter ``l``'s (0 for a shared measurement) estimate of ``[a, dv]`` and
    its 6 x 6 covariance into ``p[s:s + STATE_PARAMS]``, for a measurement whose rows depend
    on the filter's own uncertainty (:attr:`Measurement.wants_state`: a second-order,
    Gaussian-filter correction of a row, issue 15); ``a`` is the attitude block at ``o_a``
    (the SINS's ``phi``, or the DR's ``phi_D`` for rows resolved with the DR's attitude,
    :attr:`Measurement.state_attitude`), ``dv`` at ``o_v``; ``s`` is the parameter row's last
    :data:`~inmotion.estimation.measurements.STATE_PARAMS` values; after them the estimate
    of the 3-angle ``mount`` block at ``o_m`` and its covariance with ``[a, dv, mount]``
    (zeros for ``o_m`` < 0)."""
    if l < 0:
        l = 0
    for a in range(6):
        ia = o_a + a if a < 3 else o_v + a - 3
        p[s + a] = X[l, ia]
        for b in range(6):
            ib = o_a + b if b < 3 else o_v + b - 3
            p[s + 6 + 6 * a + b] = P[l, ia, ib]
    for a in range(3):
        p[s + ST_MOUNT + a] = X[l, o_m + a] if o_m >= 0 else 0.0
        for b in range(9):
            ib = o_a + b if b < 3 else o_v + b - 3 if b < 6 else o_m + b - 6
            p[s + ST_MOUNT_COV + 9 * a + b] = P[l, o_m + a, ib] if o_m >= 0 else 0.0


@njit(cache=True)
def _record_predict(phc, act, PhiT):
    """Compose the epoch's transition into ``phc`` (``Phi_k Phi_c``; ``Phi_k`` is the
    identity but on the predict's active rows ``act``, whose transposed rows are ``PhiT``'s
    first ``na`` columns, from the predict's workspace).

    It takes arrays, not ``S``, ``C`` (a call with the namedtuples costs ~0.5 us of
    reference counting, every epoch of a smoother's forward pass); ``P_k|k-1`` is copied by
    the caller at the epochs that record only. A loop over ``Phi_a``'s nonzeros into a
    buffer allocated once was tried and is slower than this dense product (0.76 against
    0.55 us a call, n = 22, 9 active rows, load ~2)."""
    na = act.shape[0]
    n = phc.shape[0]
    if na:
        tmp = PhiT.T @ phc           # PhiT's columns past na are zero padding (rows ignored)
        for a in range(na):
            for c in range(n):
                phc[act[a], c] = tmp[a, c]


@njit(cache=True)
def _record_epoch(S, O, t_now):
    """One smoother record (module :mod:`~inmotion.estimation.smoother`): the transition
    since the last record, ``P`` predicted at this epoch, ``x``, ``P`` after its updates and
    feedback, the accumulated feedback, the corrected SINS; the composite restarts."""
    i = O.nrec[0]
    O.rec_t[i] = t_now
    O.rec_epoch[i] = S.ints[_I_EPOCHS]
    O.rec_phi[i] = S.phc
    O.rec_ppred[i] = S.ppred
    O.rec_x[i] = S.X[0]
    O.rec_p[i] = S.P[0]
    O.rec_fed[i] = S.fed_back
    O.rec_xs[i] = S.xs
    O.nrec[0] = i + 1
    n = S.phc.shape[0]
    for p in range(n):
        for c in range(n):
            S.phc[p, c] = 1.0 if p == c else 0.0


@njit(cache=True)
def _epoch_outputs(S, C, O, t_now, x_g, P_g, applied, last):
    """The rare end-of-epoch work, after the predict and the samples: the smoother's record
    and the output row (a call with the namedtuples ``S``, ``C``: 0.5 us of reference
    counting, paid at output and record epochs only)."""
    if C.record and (applied or last or S.ints[_I_EPOCHS] % C.out_every == 0):
        _record_epoch(S, O, t_now)   # only where the smoother has something to say
    if S.ints[_I_EPOCHS] % C.out_every == 0:
        _write_output(S, C, O, t_now, x_g, P_g)


@njit(cache=True)
def _keep_alive(*arrays):
    """Nothing: a use that keeps the arrays (owners of borrowed views) alive up to here."""
    return len(arrays)


@njit(cache=True)
def _advance(S, C, fills, accs, t, dtheta, dvel, dt, ds, v, dth_dr, rows, qt, qj, qd, O,
             flush, t_last):
    """Run IMU rows ``t`` (M,) through the filter (module docstring); ``ds``, ``v`` (M,) the
    DR's sensor distance and speed per row, ``dth_dr`` (M, 3) the DR's own gyro rows or an
    empty (0, 3) array; ``rows`` (J, M, R) the measurements' row data for their
    accumulators; ``qt``, ``qj``, ``qd`` the queued samples (time, kind, data).
    ``flush``: close a partial last epoch, at the last row's time (``t_last`` [s], the last
    row before this call, when ``t`` is empty). Returns the number of queued samples consumed.

    One loop, every epoch the same code (issue 13): the predict inline, then, at an epoch
    with due samples, each sample's fill and its scalar Joseph rows through calls that take
    arrays only (a call passing the namedtuples ``S``, ``C`` costs an incref and a decref of
    each of their ~50 arrays, 0.5 us, and so does a function inlined with them); only the
    rare paths (FDI, shared measurements, the fused estimate, records, output rows) pass
    ``S``, ``C``."""
    # S, C, O as borrowed tuples: the rare paths that take them (FDI, the fused estimate,
    # records, output rows) pass ~50 arrays each, an atomic increment and decrement each
    # (~390 an output epoch) when they own references
    S, C, O = borrowed(S), borrowed(C), borrowed(O)
    n = S.X.shape[1]
    F_own = np.zeros((n, n))
    # each local filter's Qc with the DR's position noise: copied once, the dp_D diagonal
    # set every row (_dr_position_noise)
    Q_own = np.empty((S.X.shape[0] if C.with_dr else 0, n, n))
    for l in range(Q_own.shape[0]):
        Q_own[l] = C.Qc[l]
    aux = np.zeros(AUX_SIZE)
    dmax = 1
    for j in range(C.dofs.shape[0]):
        dmax = max(dmax, C.dofs[j])
    z_own = np.zeros(dmax)
    H_own = np.zeros((dmax, n))
    r_own = np.zeros(2 * dmax)        # r, then a measurement's test variances (test_r)
    xw_own = np.empty(n)
    xa_own = np.zeros(n)              # the test covariance's predict: its x is not used
    Pw_own = np.empty((n, n))
    xg_own = np.zeros(n)
    Pg_own = np.zeros((n, n))
    th_nb = np.zeros(3)
    v_old = np.zeros(3)
    C_own = np.empty((3, 3))
    f_b = np.empty(3)
    fn_own = np.empty(3)
    vel_own = np.empty(3)
    nan = np.nan
    own_dr_gyro = dth_dr.shape[0] > 0
    qi = 0
    # the arrays and constants, bound once (no S, C in the per-row and per-sample paths);
    # those of the per-row path as borrowed views (no reference counting: an atomic
    # increment and decrement each time one is bound, indexed or passed, 33 a row before,
    # ~0.09 s per hour): S, C and the *_own arrays keep their memory alive for the call
    xs, ms, xd, md, acc, X, P, ints, t_end = (borrowed(S.xs), borrowed(S.ms), borrowed(S.xd),
                                              borrowed(S.md), borrowed(S.acc), borrowed(S.X),
                                              borrowed(S.P), S.ints, S.t_end)
    bias_g, bias_a, fed_back, macc = borrowed(S.bias_g), borrowed(S.bias_a), S.fed_back, S.macc
    used, rejected, nis_sum, dof_sum = S.used, S.rejected, S.nis_sum, S.dof_sum
    F, Q, C_S, f_n, vel = (borrowed(F_own), borrowed(Q_own), borrowed(C_own), borrowed(fn_own),
                           borrowed(vel_own))
    dtheta, dvel = borrowed(dtheta), borrowed(dvel)
    Qc, ws, offs9, inv_tau_dk, dr_eps = borrowed(C.Qc), C.ws, C.offs9, C.inv_tau_dk, \
        C.dr_eps
    # the predict kernel's address and buffer, bound once; the sizes checked once here (the
    # kernel reads and writes n and n x n entries through raw pointers)
    k_addr, k_buf = ws.kernel, borrowed(ws.buf)
    if (ws.act.shape[0] + ws.inact.shape[0] != n or P.shape[1] != n or P.shape[2] != n
            or Qc.shape[1] != n or Qc.shape[2] != n):
        raise ValueError("_advance: the predict workspace's n is not the filter's")
    itau_g, itau_a = C.inv_tau_b[0], C.inv_tau_b[1]
    grav_grad, with_dr, o_dpD, q_dr_m2_s = C.grav_grad, C.with_dr, C.offs[DP_D], C.q_dr_m2_s
    offs, params, dofs, local, gates, has_acc = borrowed(C.offs), borrowed(C.params), C.dofs, \
        C.local, C.gates, C.has_acc
    # the sample path's arrays, borrowed too (~107 atomic operations an update epoch before:
    # the fills' and the scalar update's arguments)
    z, H, r, xw, Pw = (borrowed(z_own), borrowed(H_own), borrowed(r_own), borrowed(xw_own),
                       borrowed(Pw_own))
    Pa, xa, Qa = borrowed(S.Pa), borrowed(xa_own), borrowed(C.Qa)
    aux_own = aux
    aux, macc, qd, rows = borrowed(aux_own), borrowed(macc), borrowed(qd), borrowed(rows)
    isolate, log_nis, fb_mask, fb_states = C.isolate, C.log_nis, C.fb_mask, C.fb_states
    pstate, pstate_att, test_r = C.pstate, C.pstate_att, C.test_r
    x_g, P_g, fed_back, fb_mask, fb_states = (borrowed(xg_own), borrowed(Pg_own),
                                              borrowed(fed_back), borrowed(fb_mask),
                                              borrowed(fb_states))
    feedback_every, out_every, step, need_nb = C.feedback_every, C.out_every, C.step, C.need_nb
    C_bm, l_b = C.C_bm, C.l_b
    span_on = macc.shape[1] > ACC_SIZE       # return_span: the span's columns (issue 15)
    invariant = C.invariant and fb_mask[DV] and fb_mask[PHI]
    v_inv = np.zeros(3)
    v_pre = np.zeros(3)
    any_isolate = False               # without FDI the global estimate's source is fixed
    for j in range(isolate.shape[0]):
        any_isolate = any_isolate or isolate[j]
    record = C.record            # a smoother's forward pass records every epoch's transition
    phc, ppred = S.phc, S.ppred
    n_q = qt.shape[0]
    M = t.shape[0]
    # the next output epoch (every out_every-th): a comparison per epoch, not an integer
    # division (~40-90 cycles)
    next_out = (ints[_I_EPOCHS] // out_every + 1) * out_every
    for k in range(M + 1):
        if k < M:
            dtk = dt[k]
            dth, dvl = compensated_row(dtheta, dvel, k, dtk, bias_g, bias_a)
            if need_nb:
                for i in range(3):
                    v_old[i] = xs[K.VE + i]
            K.sins_step(xs, ms, dth, dvl, dtk, nan, 0.0, 0.0)
            ms[K.M_COUNT] += 1.0
            if with_dr:
                if own_dr_gyro:
                    if dr_eps:
                        g = (dth_dr[k, 0] - bias_g[0] * dtk, dth_dr[k, 1] - bias_g[1] * dtk,
                             dth_dr[k, 2] - bias_g[2] * dtk)
                    else:
                        g = (dth_dr[k, 0], dth_dr[k, 1], dth_dr[k, 2])
                elif dr_eps:
                    g = dth
                else:       # the printed model's DR has no drift: nothing is compensated
                    g = (dtheta[k, 0], dtheta[k, 1], dtheta[k, 2])
                K.dr_step(xd, md, g, ds[k], v[k], dtk, C_bm, l_b)
                md[K.M_COUNT] += 1.0
            if need_nb:     # body rate w.r.t. n over the row, for rate-dependent measurements
                Cnb = dcm_of_q(xs[K.Q0:K.Q3 + 1])
                w_in = K.omega_ie_n(xs[K.LAT])
                w_en = K.omega_en_n(xs[K.LAT], xs[K.H], (xs[K.VE], xs[K.VN], xs[K.VU]))
                for i in range(3):
                    acc_i = 0.0
                    for jj in range(3):
                        acc_i += Cnb[jj, i] * (w_in[jj] + w_en[jj])
                    th_nb[i] = dth[i] - acc_i * dtk
                    acc[_A_NB + i] += th_nb[i]
                for j in range(has_acc.shape[0]):
                    if has_acc[j]:
                        accs[j](macc[j], xs, v_old, th_nb, dtk, rows[j, k], params[j])
            acc[_A_ROWS] += 1.0
            acc[_A_DT] += dtk
            for i in range(3):
                acc[_A_F + i] += dvl[i]
                acc[_A_W + i] += dth[i]
            if acc[_A_ROWS] < step:
                continue
            t_now = t[k]
            last = False
        else:                              # after the rows: close a partial last epoch
            if not (flush and acc[_A_ROWS] > 0):
                break
            t_now = t[M - 1] if M > 0 else t_last
            last = True
        # ---- the epoch's predict: F at the SINS state with the epoch's mean specific force
        sum_dt = acc[_A_DT]
        K.dcm_from_quat_into((xs[K.Q0], xs[K.Q0 + 1], xs[K.Q0 + 2], xs[K.Q3]), C_S)
        for i in range(3):
            f_b[i] = acc[_A_F + i] / sum_dt
            vel[i] = xs[K.VE + i]
        for i in range(3):
            f_n[i] = C_S[i, 0] * f_b[0] + C_S[i, 1] * f_b[1] + C_S[i, 2] * f_b[2]
        # F was zeroed once: _fill_F overwrites its structural entries (error_model.F_pattern)
        em._fill_F(F, offs9, xs[K.LAT], xs[K.H], vel, C_S, f_n, inv_tau_dk, dr_eps,
                   grav_grad, itau_g, itau_a)
        for l in range(Pa.shape[0]):       # the test covariance first (the same Phi)
            if with_dr:
                _dr_position_noise(Q[l], Qa[l], o_dpD, xs[K.LAT], xs[K.H], q_dr_m2_s)
                predict_kernel_call(k_addr, xa, Pa[l], F, Q[l], sum_dt, k_buf)
            else:
                predict_kernel_call(k_addr, xa, Pa[l], F, Qa[l], sum_dt, k_buf)
        for l in range(X.shape[0]):
            if with_dr:
                _dr_position_noise(Q[l], Qc[l], o_dpD, xs[K.LAT], xs[K.H], q_dr_m2_s)
                predict_kernel_call(k_addr, X[l], P[l], F, Q[l], sum_dt, k_buf)
            else:
                predict_kernel_call(k_addr, X[l], P[l], F, Qc[l], sum_dt, k_buf)
        ints[_I_EPOCHS] += 1
        out_now = ints[_I_EPOCHS] == next_out          # ints[_I_EPOCHS] % out_every == 0
        if out_now:
            next_out += out_every
        t_end[0] = t_now
        if record:                     # the forward pass of a smoother: Phi, P_k|k-1
            _record_predict(phc, ws.act, ws.PhiT)
            # P_k|k-1 is read only at the epochs that record (_epoch_outputs: samples due,
            # the last epoch, an output epoch)
            if (qi < n_q and qt[qi] <= t_now) or last or out_now:
                P0 = P[0]
                for i in range(n):
                    for c in range(n):
                        ppred[i, c] = P0[i, c]
        # ---- the samples that fell due, in queue order
        applied = False
        if qi < n_q and qt[qi] <= t_now:
            aux[AUX_T] = t_now
            for i in range(3):
                aux[AUX_WIB + i] = acc[_A_W + i] / sum_dt
                aux[AUX_FB + i] = f_b[i]
                aux[AUX_WNB + i] = acc[_A_NB + i] / sum_dt
            while qi < n_q and qt[qi] <= t_now:
                j = qj[qi]
                _clear_rows(z, H, r, dofs[j], test_r[j])
                if pstate[j] >= 0:       # the filter's own phi, dv estimate and covariance
                    _state_to_params(params[j], pstate[j], X, P, local[j],
                                     offs[pstate_att[j]], offs[DV], C.o_mount3)
                m = fills[j](xs, xd, aux, macc[j], qd[qi], params[j], offs, z, H, r)
                applied = True
                if m > 0:
                    l = local[j]
                    if (l >= 0 and not isolate[j] and not log_nis[j] and not test_r[j]
                            and Pa.shape[0] == 0):
                        ok, nis = sequential_joseph(X[l], P[l], z, H, r, 0, m, gates[j], xw,
                                                    Pw)
                        if ok:
                            used[j] += 1
                            nis_sum[j] += nis
                            dof_sum[j] += m
                        else:
                            rejected[j] += 1
                    elif l >= 0 and span_on and isolate[j] and has_acc[j]:   # issue 15
                        was_isolated = not S.healthy[j]
                        used_before = used[j]
                        _apply(S, C, fills, j, l, z, H, r, m, xw, Pw, t_now, True)
                        _span_sample(S, C, fills, j, l, aux, qd[qi], t_now, was_isolated,
                                     used_before, z, H, r, xw, Pw)
                    elif l >= 0:
                        _apply(S, C, fills, j, l, z, H, r, m, xw, Pw, t_now, True)
                    else:                # shared: every local filter, noise scaled (eq. 33-35)
                        for l in range(X.shape[0]):
                            _apply(S, C, fills, j, l, z, H, r, m, xw, Pw, t_now, l == 0)
                if has_acc[j]:
                    if span_on and m == 0:      # an interval lost: no span across it
                        macc[j, _SPAN + ACC_BAD] = 1.0
                    for i in range(ACC_SIZE):
                        macc[j, i] = 0.0
                qi += 1
        if applied:
            ints[_I_UPDATES] += 1
            mode = ints[_I_MODE]
            if any_isolate:
                mode = _mode_of(S.healthy, isolate, local, C.primary, C.fallback)
                if mode != ints[_I_MODE]:
                    _log_event(S, t_now, -1, EVENT_MODE, mode)
                    ints[_I_MODE] = mode
            if (feedback_every > 0 and ints[_I_UPDATES] % feedback_every == 0
                    and mode != MODE_NONE):
                if mode >= 0 and not C.fuse_isolated:   # one local's (_global without P_g)
                    x_g[:] = X[mode]
                else:
                    _global(S, C, mode, x_g, P_g)
                if invariant:             # the velocity before, and the retraction's velocity
                    _invariant_velocity(xs, x_g, offs[PHI], offs[DV], v_pre, v_inv)
                _feed_back_arrays(xs, ms, xd, md, bias_g, bias_a, fed_back, X, offs, fb_mask,
                                  fb_states, with_dr, x_g)
                if invariant:
                    for i in range(3):
                        ms[K.M_V_OLD + i] += v_inv[i] - xs[K.VE + i]
                        xs[K.VE + i] = v_inv[i]
                        # the accumulated feedback holds the velocity change made (the
                        # smoother's fb = -dV, from which it undoes the reset)
                        fed_back[offs[DV] + i] += v_pre[i] - v_inv[i] - x_g[offs[DV] + i]
                    _invariant_velocity_reset(P, X, Pa, offs[PHI], offs[DV],
                                              (v_pre[0] - v_inv[0], v_pre[1] - v_inv[1],
                                               v_pre[2] - v_inv[2]))
                if span_on:
                    _span_feedback(macc, isolate, has_acc, x_g, offs, fb_mask)
        if record or out_now:
            _epoch_outputs(S, C, O, t_now, x_g, P_g, applied, last)
        for i in range(_A_SIZE):
            acc[i] = 0.0
    # the borrowed views' memory
    _keep_alive(F_own, Q_own, C_own, fn_own, vel_own, z_own, H_own, r_own, xw_own, Pw_own,
                aux_own, xg_own, Pg_own, xa_own)
    return qi


# ----------------------------------------------------------------------------- the filter
def _aot_name(f) -> str:
    """``module.qualname`` of a fill or accumulator (how :mod:`inmotion._aot` names it)."""
    py = getattr(f, "py_func", f)
    return f"{py.__module__}.{py.__qualname__}"


def _feedback_mask(feedback, layout):
    if feedback == "closed":
        blocks = FEEDBACK_BLOCKS
    elif feedback == "open":
        blocks = ()
    else:
        blocks = tuple(feedback)
        bad = [b for b in blocks if b not in FEEDBACK_BLOCKS]
        if bad:
            raise ValueError(f"feedback blocks must be among {FEEDBACK_BLOCKS}, got {bad}")
    mask = np.zeros(len(layout.offsets()), dtype=np.bool_)
    states = np.zeros(layout.n, dtype=np.bool_)
    for b in blocks:
        mask[_FB_INDEX[FEEDBACK_BLOCKS.index(b)]] = True
        if b in layout:
            states[layout[b]] = True
    return mask, states


class LocalFilter:
    """One local filter of a bank (paper 003's sub-filters and vehicle-constraint filter).

    Parameters
    ----------
    P0 : (n, n) initial covariance;  Qc : (n, n) continuous process noise (default: the
        model's)
    r_scale : float, noise scale of shared measurements on this filter (``1 / beta``)
    fuse_weight : float, the weight of this filter's information in the fusion (``beta``
        where the sharing is taken at the fusion, :mod:`inmotion.estimation.federated`;
        1: eq. 36 as printed)
    role : ``"primary"`` (fused when healthy) or ``"fallback"`` (the global estimate only
        when no primary is healthy)
    P0_test, Qc_test : (n, n) the test covariance's start and process noise (the engine's
        "Test covariance"; default ``P0``, ``Qc``): the true prior and the IMU's own noise
        where a bank's sub-filter carries ``1 / beta`` on both (paper 003 eq. 33-35)
    """

    def __init__(self, P0, Qc=None, *, r_scale: float = 1.0, role: str = "primary",
                 P0_test=None, Qc_test=None, fuse_weight: float = 1.0):
        if role not in ("primary", "fallback"):
            raise ValueError(f"role must be 'primary' or 'fallback', got {role!r}")
        self.P0 = np.array(P0, dtype=float)
        self.Qc = None if Qc is None else np.array(Qc, dtype=float)
        self.P0_test = self.P0 if P0_test is None else np.array(P0_test, dtype=float)
        self.Qc_test = self.Qc if Qc_test is None else np.array(Qc_test, dtype=float)
        self.r_scale = float(r_scale)
        if not 0.0 < fuse_weight <= 1.0:
            raise ValueError(f"fuse_weight must be in (0, 1], got {fuse_weight}")
        self.fuse_weight = float(fuse_weight)
        self.role = role


class ErrorStateFilter:
    """Streaming closed-loop error-state Kalman filter (see the module docstring).

    Parameters
    ----------
    init : NavState
        Start of the SINS (and of the DR).
    layout : Layout
        The error state; must hold ``phi, dv, dp``; ``phi_D, dp_D`` make the filter run a
        dead reckoner beside the SINS.
    model : error_model.ErrorModel
        On ``layout``: ``F`` (the one shared builder) and ``Q_c``.
    P0 : (n, n) initial covariance, in the layout's SI units; or a list of
        :class:`LocalFilter` (a bank on the one navigation system).
    measurements : list of Measurement
        At most :data:`MAX_MEASUREMENTS`, with distinct names; applied in this order when
        samples share a time. A measurement's ``local`` attribute picks its local filter
        (index; ``None``: every local, with the local's ``r_scale``).
    step_rows : int
        IMU rows per filter epoch (a predict per epoch).
    feedback : ``"closed"``, ``"open"`` or a list of blocks of :data:`FEEDBACK_BLOCKS`
        (partial feedback).
    feedback_every : int
        Epochs with applied samples per feedback.
    out_every : int
        Filter epochs per output row of :meth:`add_imu`.
    dr_mounting : (3, 3) ``C_m^b`` of the DR's velocity sensor (identity by default).
    dr_lever_arm_m : (3,) IMU-to-sensor lever arm in b [m] (zeros by default).
    dr_position_m2_s : float
        DR position random-walk density [m^2/s] (the sensor's white noise integrated).
    n_common : int
        Leading states fused across primaries (bank only; default: the fed-back states).
    max_events, max_nis : capacity of the event log and of the NIS series.
    fuse_isolated : bool
        While a primary local's measurement is isolated and another primary is healthy, the
        global estimate fuses every primary, the isolated one's prediction too (module
        docstring); default False: Table 1 as printed, the healthy primaries alone.
    return_conditioned : bool
        An isolated measurement is tested on a copy of its local filter conditioned on the
        other healthy primaries' common estimate, and is on probation after its return
        (module docstring, "Isolate and return"); default False: tested on its masked local
        filter alone.
    return_span, return_span_max_s : bool, float [s]
        At the return of an isolated measurement with a row accumulator (a displacement
        increment), the intervals whose samples were not applied since the last applied one
        and the returning one are filled as one interval (the span), tested as the isolated
        samples are and, passed, applied to the local filter (module docstring, "Return
        span"); spans longer than ``return_span_max_s`` are not applied, nor those of a
        measurement whose ``spans`` is False (e.g. a velocity). Default False: the returning
        sample is not applied, the isolation's intervals are lost.
    test_covariance : bool
        Each local filter carries the test covariance ``Pa`` (from its ``P0_test``, with its
        ``Qc_test``; module docstring, "Test covariance"), and its own residual tests take
        ``H Pa H^T`` with the rows' test variances; ``P`` and the estimates are unchanged, the
        predict and update cost about doubles. Default False.
    record : keep what a Rauch-Tung-Striebel smoother needs
        (:mod:`inmotion.estimation.smoother`; one local filter only), at every epoch that
        applied samples, every output epoch and the last one, with the transition composed
        over the epochs between: :meth:`add_imu` then returns it under ``"record"``.
    phi_order : int
        The transition's order in ``F dt``: 2 (default) ``Phi = I + F dt + (F dt)^2 / 2``,
        1 ``Phi = I + F dt`` (KF-GINS's discretization, a cheaper predict: module docstring
        of :mod:`~inmotion.estimation.predict`, "First order"); the trapezoid ``Q_d`` either
        way.
    """

    def __init__(self, init: NavState, layout: Layout, model: em.ErrorModel, P0,
                 measurements, *, step_rows: int = 1, feedback="closed", feedback_every: int = 1,
                 out_every: int = 1, dr_mounting=None, dr_lever_arm_m=None,
                 dr_position_m2_s: float = 0.0, n_common: int | None = None,
                 max_events: int = 100000, max_nis: int = 0, record: bool = False,
                 fuse_isolated: bool = False, phi_order: int = 2,
                 return_conditioned: bool = False, return_span: bool = False,
                 return_span_max_s: float = math.inf, test_covariance: bool = False,
                 invariant_velocity: bool = False):
        if phi_order not in (1, 2):
            raise ValueError(f"phi_order must be 1 or 2, got {phi_order!r}")
        for name in ("phi", "dv", "dp"):
            if name not in layout:
                raise ValueError(f"the filter needs block {name!r} in the layout")
        if model.layout is not layout and tuple(model.layout.names) != tuple(layout.names):
            raise ValueError("the error model is built on another layout")
        measurements = list(measurements)
        if len(measurements) > MAX_MEASUREMENTS:
            raise ValueError(f"at most {MAX_MEASUREMENTS} measurement kinds per filter, got "
                             f"{len(measurements)}")
        names = [m.name for m in measurements]
        if len(set(names)) != len(names):
            raise ValueError(f"measurement names must be distinct, got {names}")
        with_dr = "phi_D" in layout
        n = layout.n
        locals_ = (list(P0) if isinstance(P0, (list, tuple)) and P0
                   and isinstance(P0[0], LocalFilter) else [LocalFilter(P0)])
        L = len(locals_)
        if with_dr and L > 1:
            raise ValueError("a bank of local filters runs on the SINS alone (no DR blocks)")
        if record and L > 1:
            raise ValueError("smoother records are kept for one local filter only")
        for lf in locals_:
            if lf.P0.shape != (n, n):
                raise ValueError(f"P0 must be ({n}, {n}) for {layout!r}, got {lf.P0.shape}")
            if lf.P0_test.shape != (n, n):
                raise ValueError(f"P0_test must be ({n}, {n}) for {layout!r}, got "
                                 f"{lf.P0_test.shape}")
        for m in measurements:
            if not isinstance(m, Measurement):
                raise TypeError(f"not a Measurement: {m!r}")
            if m.needs_dr and not with_dr:
                raise ValueError(f"measurement {m.name!r} needs the DR blocks phi_D, dp_D")
            loc = getattr(m, "local", 0)
            if loc is not None and not 0 <= loc < L:
                raise ValueError(f"measurement {m.name!r}: local filter {loc} of {L}")
            m.check(layout)
        if int(step_rows) < 1 or int(out_every) < 1 or int(feedback_every) < 1:
            raise ValueError("step_rows, out_every and feedback_every must be >= 1")
        self.init = init
        self.layout = layout
        self.model = model
        self.measurements = measurements
        self.locals = locals_
        self._index = {m.name: j for j, m in enumerate(measurements)}
        self.step = int(step_rows)
        self.out_every = int(out_every)
        x0 = _state_vector(init)
        fb_mask, fb_states = _feedback_mask(feedback, layout)
        if n_common is None:
            n_common = int(np.argmin(fb_states)) if not fb_states.all() else n
        if L > 1 and not (fb_states[:n_common].all() and not fb_states[n_common:].any()):
            raise ValueError("a bank fuses the leading n_common states: they must be exactly "
                             "the fed-back ones")
        C_bm = np.eye(3) if dr_mounting is None else np.array(dr_mounting, dtype=float)
        l_b = np.zeros(3) if dr_lever_arm_m is None else np.array(dr_lever_arm_m, dtype=float)
        if C_bm.shape != (3, 3) or l_b.shape != (3,):
            raise ValueError("dr_mounting must be (3, 3) and dr_lever_arm_m (3,)")
        M = MAX_MEASUREMENTS
        n_par = max([len(m.params()) + (STATE_PARAMS if getattr(m, "wants_state", False)
                                         else 0) for m in measurements] + [1])
        params = np.zeros((M, n_par))
        for j, m in enumerate(measurements):
            p = np.asarray(m.params(), dtype=float)
            params[j, :len(p)] = p
        self._data_size = max([m.data_size for m in measurements] + [1])
        self._row_size = max([m.row_data_size for m in measurements] + [1])

        def per_meas(f, fill, dtype=float):
            return np.array([f(m) for m in measurements] + [fill] * (M - len(measurements)),
                            dtype=dtype)

        has_acc = per_meas(lambda m: m.accumulate is not None, False, np.bool_)
        def stack_qc(attr):       # each local's process noise (None: the model's)
            return np.stack([np.ascontiguousarray(model.Qc() if getattr(lf, attr) is None
                                                  else getattr(lf, attr)) for lf in locals_])

        Qc = stack_qc("Qc")
        offs = layout.offsets()
        offs9 = tuple(int(o) for o in em._offsets(layout))
        q_pattern = (Qc != 0).any(axis=0)
        if with_dr:                     # the DR position random walk (dp_D's diagonal)
            q_pattern[layout["dp_D"], layout["dp_D"]] = True
        ws = make_workspace(model.F_pattern(), q_pattern, phi_order)
        #: whether the feedback is the invariant velocity one (module docstring)
        self.invariant_velocity = bool(invariant_velocity)
        #: ``info['velocity_error']`` of the methods: ``invariant`` or ``standard``
        self.velocity_error = "invariant" if self.invariant_velocity else "standard"
        self._C = _Const(
            offs=offs, offs9=offs9, Qc=Qc,
            q_dr_m2_s=float(dr_position_m2_s), inv_tau_dk=1.0 / model.noise.dk_tau,
            inv_tau_b=np.array(model.noise.inv_tau_bias, dtype=float),
            dr_eps=bool(model.dr_sees_gyro_drift), grav_grad=bool(model.gravity_gradient),
            with_dr=with_dr, step=self.step, out_every=self.out_every, fb_mask=fb_mask,
            fb_states=fb_states, feedback_every=int(feedback_every) if fb_mask.any() else 0,
            C_bm=np.ascontiguousarray(C_bm), l_b=l_b,
            gates=per_meas(lambda m: m.gate, 0.0), params=params,
            dofs=per_meas(lambda m: m.dof, 0, np.int64),
            local=per_meas(lambda m: -1 if getattr(m, "local", 0) is None else m.local, 0,
                           np.int64),
            r_scale=np.array([lf.r_scale for lf in locals_]),
            isolate=per_meas(lambda m: m.isolate, False, np.bool_),
            return_tests=per_meas(lambda m: m.return_tests, 1, np.int64),
            primary=np.array([lf.role == "primary" for lf in locals_]),
            fallback=np.array([lf.role == "fallback" for lf in locals_]),
            n_common=int(n_common),
            need_nb=bool(has_acc.any() or any(m.needs_body_rate for m in measurements)),
            has_acc=has_acc, log_nis=per_meas(lambda m: m.isolate or m.log_nis, False,
                                                np.bool_), ws=ws, record=bool(record),
            fuse_isolated=bool(fuse_isolated),
            pstate=per_meas(lambda m: n_par - STATE_PARAMS if getattr(m, "wants_state", False)
                            else -1, -1, np.int64),
            pstate_att=per_meas(lambda m: KERNEL_BLOCKS.index(m.state_attitude), PHI,
                                np.int64),
            o_mount3=(int(layout["mount"].start) if "mount" in layout
                      and layout["mount"].stop - layout["mount"].start == 3 else -1),
            return_conditioned=bool(return_conditioned),
            invariant=bool(invariant_velocity),
            fuse_w=np.array([lf.fuse_weight for lf in locals_]),
            test_r=per_meas(lambda m: getattr(m, "test_variance", False), False, np.bool_),
            Qa=stack_qc("Qc_test") if test_covariance else np.zeros((0, n, n)))
        # the fill and accumulator functions (numba functions, compiled or loaded at first use
        # by the JIT path: _fills, _accs)
        self._fill_objs = tuple([m.fill for m in measurements]
                                + [_noop_fill] * (M - len(measurements)))
        self._acc_objs = tuple([m.accumulate if m.accumulate is not None else _noop_acc
                                for m in measurements] + [_noop_acc] * (M - len(measurements)))
        self._S = _State(
            xs=x0.copy(), ms=K.new_memory(), xd=x0.copy(), md=K.new_memory(),
            X=np.zeros((L, n)), P=np.stack([lf.P0 for lf in locals_]), fed_back=np.zeros(n),
            bias_g=np.zeros(3), bias_a=np.zeros(3), acc=np.zeros(_A_SIZE),
            ints=np.zeros(5, dtype=np.int64),
            used=np.zeros(M, dtype=np.int64), rejected=np.zeros(M, dtype=np.int64),
            nis_sum=np.zeros(M), dof_sum=np.zeros(M, dtype=np.int64),
            t_end=np.array([float(init.t)]), healthy=np.ones(M, dtype=np.bool_),
            normal_run=np.zeros(M, dtype=np.int64), tests=np.zeros(M, dtype=np.int64),
            exceed=np.zeros(M, dtype=np.int64),
            macc=np.zeros((M, _SPAN_COLS if return_span else ACC_SIZE)),
            ev=np.zeros((int(max_events), 4)), nis_log=np.zeros((int(max_nis), 3)),
            phc=np.eye(n) if record else np.zeros((0, 0)),
            ppred=np.zeros((n, n) if record else (0, 0)),
            Pa=(np.stack([lf.P0_test for lf in locals_]) if test_covariance
                else np.zeros((0, n, n))))
        if return_span:
            if not return_span_max_s > 0.0:
                raise ValueError(f"return_span_max_s must be > 0, got {return_span_max_s!r}")
            for j, m in enumerate(measurements):        # 0: never a span (a velocity)
                if m.spans and m.isolate and m.accumulate is not None:
                    self._S.macc[j, _SPAN_LIM] = float(return_span_max_s)
        self.return_span = bool(return_span)
        # the loop compiled ahead of time for this filter's functions and types, if any
        # (inmotion._aot: no numba on the run path); else numba's JIT
        self._aot = _aot.case([_aot_name(f) for f in self._fill_objs],
                              [_aot_name(f) for f in self._acc_objs], self._S, self._C)
        self._S.ints[_I_MODE] = (self._aot.mode if self._aot else _mode)(self._S, self._C)
        self.t = float(init.t)           #: time of the last IMU row processed [s]
        self.rows = 0                    #: IMU rows processed
        self._qt = np.zeros(0)
        self._qj = np.zeros(0, dtype=np.int64)
        self._qd = np.zeros((0, self._data_size))
        self._pending = []
        self._fed_last = np.zeros(n)        # accumulated feedback before the last record

    # -- input ---------------------------------------------------------------------------
    def add_measurement(self, name: str, t, data=None):
        """Queue one sample (``t`` a float) or many (``t`` (K,), ``data`` (K, size)) of the
        measurement ``name``; each is applied at the end of the first filter epoch that ends
        at or after its time [s]."""
        try:
            j = self._index[name]
        except KeyError:
            raise KeyError(f"no measurement {name!r} in this filter; it has "
                           f"{', '.join(self._index) or 'none'}") from None
        size = self.measurements[j].data_size
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if t.ndim != 1:
            raise ValueError(f"{name}: t must be a time or a 1-D array of times")
        if size == 0:
            d = np.zeros((len(t), 0))
        else:
            d = np.asarray(data, dtype=float).reshape(len(t), size)
        if not np.all(np.isfinite(t)):
            raise ValueError(f"{name}: sample times must be finite")
        block = np.zeros((len(t), self._data_size))
        block[:, :size] = d
        self._pending.append((t, np.full(len(t), j, dtype=np.int64), block))

    def _merge_pending(self):
        if not self._pending:
            return
        ts = [self._qt] + [p[0] for p in self._pending]
        js = [self._qj] + [p[1] for p in self._pending]
        ds = [self._qd] + [p[2] for p in self._pending]
        self._pending = []
        t = np.concatenate(ts)
        order = np.argsort(t, kind="stable")
        self._qt = np.ascontiguousarray(t[order])
        self._qj = np.ascontiguousarray(np.concatenate(js)[order])
        self._qd = np.ascontiguousarray(np.concatenate(ds)[order])

    def add_imu(self, t, dtheta, dvel, *, ds=None, speed=None, dtheta_dr=None,
                row_data: dict | None = None, flush: bool = False,
                max_out: int | None = None) -> dict:
        """Process IMU rows: mechanization, a predict per ``step_rows`` rows, the queued
        samples that fall due, feedback.

        Parameters
        ----------
        t : (M,) s, after the last row processed;  dtheta, dvel : (M, 3) rad, m/s increments
            in b over the interval ending at ``t``
        ds, speed : (M,) the DR's velocity-sensor distance [m] over each row and speed [m/s]
            at ``t`` (required when the filter has a DR)
        dtheta_dr : (M, 3) rad, the DR's own gyro rows (default: the SINS's)
        row_data : {measurement name: (M,) or (M, R)} the per-row data of measurements with
            an accumulator (e.g. a sensor's distance over each row)
        flush : close a partial last epoch (the end of a run)
        max_out : output rows to make room for (default: all this call can write)

        Returns
        -------
        dict of the output rows written (every ``out_every``-th epoch): ``t`` (R,),
        ``x_sins`` (R, 10) kernel states corrected by the estimate not yet fed back,
        ``sigma`` (R, n), ``states`` (R, n) (fed back plus current), ``cov_phi`` (R, 3, 3),
        ``mode`` (R,) the global estimate's source, and with a bank ``local_x``,
        ``local_sigma`` (R, L, n).
        """
        t = np.ascontiguousarray(t, dtype=float).reshape(-1)
        m = len(t)
        dtheta = np.ascontiguousarray(dtheta, dtype=float).reshape(m, 3)
        dvel = np.ascontiguousarray(dvel, dtype=float).reshape(m, 3)
        if m and not t[0] > self.t:
            raise ValueError(f"IMU rows must follow the last one processed (t={self.t:.6f} s); "
                             f"got t={t[0]:.6f} s")
        if self._C.with_dr:
            if ds is None or speed is None:
                raise ValueError("this filter runs a dead reckoner: add_imu needs ds and speed")
            ds = np.ascontiguousarray(ds, dtype=float).reshape(m)
            speed = np.ascontiguousarray(speed, dtype=float).reshape(m)
        else:
            ds = speed = np.zeros(m)
        dth_dr = (np.zeros((0, 3)) if dtheta_dr is None
                  else np.ascontiguousarray(dtheta_dr, dtype=float).reshape(m, 3))
        rows = self._rows(row_data, m)
        dt = np.diff(np.concatenate([[self.t], t])) if m else np.zeros(0)
        self._merge_pending()
        n_ep = (int(self._S.acc[_A_ROWS]) + m) // self.step + 1
        cap = n_ep // self.out_every + 1 if max_out is None else int(max_out)
        O = self._out(cap, n_ep if self._C.record else 0)
        used = self._call_advance(t, dtheta, dvel, dt, ds, speed, dth_dr, rows, self._qt,
                                  self._qj, self._qd, O, bool(flush), float(self.t))
        if used:
            self._qt, self._qj, self._qd = self._qt[used:], self._qj[used:], self._qd[used:]
        if m:
            self.t = float(t[-1])
            self.rows += m
        return self._result(O)

    @functools.cached_property
    def _fills(self):
        """The fill functions as numba functions (compiled or loaded from numba's cache at
        the first use, by the JIT path)."""
        return tuple(dispatcher(f) for f in self._fill_objs)

    @functools.cached_property
    def _accs(self):
        """The accumulator functions as numba functions."""
        return tuple(dispatcher(f) for f in self._acc_objs)

    def _call_advance(self, *args):
        """:func:`_advance` on this filter's state with ``args``, through the compiled
        overload's entry point when one matches the arguments' types.

        A plain call of the dispatcher types every argument on every call, and typing the
        tuples of measurement functions and the namedtuples ``S``, ``C`` costs ~1.2 ms of
        the ~1.6 ms a call (issue 13: 22 calls, 0.035 s, of an hour fed in 16,384-row
        chunks); their types are fixed for the filter's life (:meth:`restore` copies into
        the same arrays), so they are typed once and only the other arguments per call.

        When the ahead-of-time extension has this filter's case (:mod:`inmotion._aot`: the
        same fills, the same argument types) the call goes there instead, and numba is not
        imported: the same compiled loop, bit-identical results (``tests/test_aot.py``).
        """
        if self._aot is not None and self._aot.args_spec == tuple(_aot.type_spec(a)
                                                                  for a in args):
            return self._aot.advance(self._S, self._C, *args)
        head = (self._S, self._C, self._fills, self._accs)
        cache = getattr(self, "_advance_types", None)
        if cache is None or any(a is not b for a, b in zip(cache[0], head)):
            cache = self._advance_types = (head, tuple(_advance.typeof_pyval(a)
                                                       for a in head))
        tys = cache[1] + tuple(_advance.typeof_pyval(a) for a in args)
        cres = _advance.overloads.get(tys)
        if cres is None:                   # first call of this signature: compile or load
            return _advance(*head, *args)
        return cres.entry_point(*head, *args)

    def _rows(self, row_data, m):
        J = len(self.measurements)
        need = [j for j, ms_ in enumerate(self.measurements) if ms_.accumulate is not None]
        # read only for measurements with an accumulator: without one, no rows (was 1 MB of
        # NaN written per 16,384-row chunk)
        rows = np.full((MAX_MEASUREMENTS if J else 0, m if need else 0, self._row_size),
                       np.nan)
        row_data = row_data or {}
        for name in row_data:
            if name not in self._index:
                raise KeyError(f"row data for {name!r}, which is not a measurement here")
        for j in need:
            name = self.measurements[j].name
            if name not in row_data:
                raise ValueError(f"measurement {name!r} accumulates per IMU row: add_imu "
                                 f"needs row_data[{name!r}]")
            d = np.asarray(row_data[name], dtype=float).reshape(m, -1)
            rows[j, :, :d.shape[1]] = d
        return rows

    def _out(self, cap, rec=0):
        n = self.layout.n
        L = len(self.locals) if len(self.locals) > 1 else 0
        return _Out(t=np.empty(cap), xs=np.empty((cap, K.NX)), sigma=np.empty((cap, n)),
                    states=np.empty((cap, n)), cov_phi=np.empty((cap, 3, 3)),
                    mode=np.empty(cap, dtype=np.int64), local_x=np.empty((cap, L, n)),
                    local_sig=np.empty((cap, L, n)), n=np.zeros(1, dtype=np.int64),
                    rec_t=np.empty(rec), rec_phi=np.empty((rec, n, n)),
                    rec_ppred=np.empty((rec, n, n)), rec_x=np.empty((rec, n)),
                    rec_p=np.empty((rec, n, n)), rec_fed=np.empty((rec, n)),
                    rec_xs=np.empty((rec, K.NX)), rec_epoch=np.empty(rec),
                    nrec=np.zeros(1, dtype=np.int64))

    def _result(self, O):
        k = int(O.n[0])
        res = {"t": O.t[:k], "x_sins": O.xs[:k], "sigma": O.sigma[:k], "states": O.states[:k],
               "cov_phi": O.cov_phi[:k], "mode": O.mode[:k]}
        if O.local_x.shape[1]:
            res["local_x"], res["local_sigma"] = O.local_x[:k], O.local_sig[:k]
        if self._C.record:
            r = int(O.nrec[0])
            fed = O.rec_fed[:r]
            fb = np.diff(np.vstack([self._fed_last[None, :], fed]), axis=0)
            if r:
                self._fed_last = fed[-1].copy()
            res["record"] = {"t": O.rec_t[:r], "phi": O.rec_phi[:r], "p_pred": O.rec_ppred[:r],
                             "x": O.rec_x[:r], "p": O.rec_p[:r], "fb": fb, "fed": fed,
                             "xs": O.rec_xs[:r], "epoch": O.rec_epoch[:r]}
        return res

    def flush(self) -> dict:
        """Close a partial filter epoch (predict over it, apply what fell due); the outputs
        written, as :meth:`add_imu`."""
        return self.add_imu(np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3)),
                            ds=np.zeros(0), speed=np.zeros(0), flush=True)

    # -- output --------------------------------------------------------------------------
    def reseed_dr_position(self) -> None:
        """Put the dead reckoner's position on the SINS's and its position error on the
        SINS's: ``[lat, lon, h]_D := [lat, lon, h]_S`` and ``dp_D := dp`` (``x' = T x``, ``P' = T
        P T^T`` with ``T`` copying the ``dp`` rows onto ``dp_D``'s; in every local filter, the
        test covariance and a smoother's transition since its last record).

        For the end of a gap in the DR's distance sensor (issue 15, session 21): across it
        the DR's distance is interpolated, so its position afterwards holds an error no state
        describes (on the simulated phone drive with the odometer out for 35 s, tens of
        metres). Reseeded, its error is exactly the SINS's, and the SINS-minus-DR position
        rows measure the DR's motion from there on."""
        S, C = self._S, self._C
        if not C.with_dr or "dp_D" not in self.layout:
            raise ValueError("reseed_dr_position needs a filter with a DR and a dp_D block")
        o, od = self.layout["dp"], self.layout["dp_D"]
        S.xd[K.LAT:K.H + 1] = S.xs[K.LAT:K.H + 1]
        for X in S.X:
            X[od] = X[o]
        for P in (*S.P, *S.Pa):
            P[od, :] = P[o, :]
            P[:, od] = P[:, o]
        if S.phc.shape[0]:
            S.phc[od, :] = S.phc[o, :]

    def output_now(self) -> dict:
        """One output row of the current state (the same fields as :meth:`add_imu`'s)."""
        O = self._out(1)
        n = self.layout.n
        write = (self._aot.write_output if self._aot is not None
                 and self._aot.out_spec == _aot.type_spec(O) else _write_output)
        write(self._S, self._C, O, self.t, np.zeros(n), np.zeros((n, n)))
        res = self._result(O)
        res.pop("record", None)
        return res

    def state(self) -> NavState:
        """The navigation solution now: the SINS corrected by the estimate not yet fed back."""
        x = self.output_now()["x_sins"][0]
        return NavState(self.t, x[K.LAT], x[K.LON], x[K.H], x[K.VE:K.VU + 1].copy(),
                        x[K.Q0:K.Q3 + 1].copy())

    def covariance(self, local: int = 0) -> np.ndarray:
        """``P`` (n, n) of a local filter (the only one by default), a copy, SI."""
        return self._S.P[local].copy()

    def sigma(self) -> dict:
        """``{state element: 1-sigma}`` of the global estimate, SI (``layout.names``)."""
        return self.layout.as_dict(self.output_now()["sigma"][0])

    def estimate(self) -> dict:
        """``{state element: fed back + current estimate}`` of the global estimate, SI: the
        accumulated error estimate (sensor errors such as ``eps_x``, ``mount_z``, ``dk``)."""
        return self.layout.as_dict(self.output_now()["states"][0])

    @property
    def x(self) -> np.ndarray:
        """The current error-state estimate of the (first) local filter, a copy."""
        return self._S.X[0].copy()

    @property
    def epochs(self) -> int:
        return int(self._S.ints[_I_EPOCHS])

    @property
    def mode(self) -> int:
        """The global estimate's source: a local filter's index, MODE_FUSED or MODE_NONE."""
        return int(self._S.ints[_I_MODE])

    def kernel_states(self):
        """``(xs, xd, aux, acc)``: copies of the SINS and DR kernel states, the last row's
        ``aux`` (:data:`inmotion.estimation.measurements.AUX_SIZE`) and a zero accumulator,
        for a measurement's :meth:`~inmotion.estimation.measurements.Measurement.rows`."""
        S = self._S
        aux = np.zeros(AUX_SIZE)
        aux[AUX_T] = self.t
        aux[AUX_WIB:AUX_WIB + 3] = S.ms[K.M_WIB:K.M_WIB + 3]
        aux[AUX_FB:AUX_FB + 3] = S.ms[K.M_FB:K.M_FB + 3]
        return S.xs.copy(), S.xd.copy(), aux, np.zeros(ACC_SIZE)

    def counts(self) -> dict:
        """Per measurement: samples used, rejected (gate or isolation), mean NIS per degree
        of freedom (``None`` before any), and with FDI the tests, exceedances while healthy
        and whether it is healthy now."""
        S = self._S
        res = {}
        for j, m in enumerate(self.measurements):
            dof = int(S.dof_sum[j])
            res[m.name] = {"used": int(S.used[j]), "rejected": int(S.rejected[j]),
                           "nis_per_dof": float(S.nis_sum[j] / dof) if dof else None}
            if m.isolate:
                res[m.name].update(tests=int(S.tests[j]), exceedances_while_healthy=int(
                    S.exceed[j]), healthy=bool(S.healthy[j]))
                if self.return_span and m.accumulate is not None:
                    mj = S.macc[j]
                    res[m.name].update(spans_applied=int(mj[_SPAN_OK]),
                                       spans_rejected=int(mj[_SPAN_BAD]),
                                       longest_span_s=float(mj[_SPAN_LONGEST]))
        return res

    def nis_sums(self) -> dict:
        """Per measurement: ``(sum of NIS, degrees of freedom used)`` (for pooled NIS)."""
        S = self._S
        return {m.name: (float(S.nis_sum[j]), int(S.dof_sum[j]))
                for j, m in enumerate(self.measurements)}

    def nis_summary(self) -> dict:
        """Per measurement kind: :func:`inmotion.estimation.chi2.nis_summary` of the applied
        samples (NIS of the first local filter for a shared measurement), for the ``nis``
        block of ``summary.json``."""
        from .chi2 import nis_summary
        S = self._S
        return {m.name: nis_summary(float(S.nis_sum[j]), int(S.dof_sum[j]), int(S.used[j]))
                for j, m in enumerate(self.measurements)}

    def events(self) -> tuple:
        """``(events, dropped)``: (E, 4) rows ``[t, measurement index (-1: mode), kind,
        value]`` (kind :data:`EVENT_DETECTED` / :data:`EVENT_RETURNED` with the NIS,
        :data:`EVENT_MODE` with the new source) and how many did not fit."""
        S = self._S
        k = int(min(S.ints[_I_EV], len(S.ev)))
        return S.ev[:k].copy(), int(S.ints[_I_EV] - k)

    def nis_series(self) -> np.ndarray:
        """(K, 3) rows ``[t, measurement index, NIS]`` of the logged measurements (FDI-tested
        ones and those with ``log_nis``), up to ``max_nis`` rows."""
        S = self._S
        return S.nis_log[:int(min(S.ints[_I_NIS], len(S.nis_log)))].copy()

    # -- checkpoints ---------------------------------------------------------------------
    def snapshot(self) -> dict:
        """A copy of the whole filter state (nav systems, estimates, covariances,
        compensation, epoch accumulators, counters, FDI state, queued samples);
        :meth:`restore` returns to it."""
        self._merge_pending()
        return {"S": _State(*(a.copy() for a in self._S)), "t": self.t, "rows": self.rows,
                "queue": (self._qt.copy(), self._qj.copy(), self._qd.copy()),
                "fed_last": self._fed_last.copy()}

    def restore(self, snap: dict):
        """Return to a :meth:`snapshot` of this filter (its arrays are copied again, so one
        snapshot can be restored many times)."""
        for dst, src in zip(self._S, snap["S"]):
            dst[...] = src
        self.t = float(snap["t"])
        self.rows = int(snap["rows"])
        qt, qj, qd = snap["queue"]
        self._qt, self._qj, self._qd = qt.copy(), qj.copy(), qd.copy()
        self._pending = []
        self._fed_last = snap["fed_last"].copy()
