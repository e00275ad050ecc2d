"""Every numerical tolerance of lpik, in one place.

The numpy path and the compiled kernels (:mod:`lpik.fast`) both read these
plain constants; numba freezes them when it compiles a kernel. numba's disk
cache does not notice a change here: after editing a value, delete the
``__pycache__`` folders under ``lpik/fast`` (or set ``NUMBA_CACHE_DIR`` to a
new folder) so that the kernels compile again.
"""

from __future__ import annotations

#: The spacing of floats at 1 (numpy's ``finfo(float).eps``), 2^-52: rounding's scale.
MACHINE_EPSILON = 2.220446049250313e-16

# ----------------------------------------------------------------- problems
#: Relative tolerance on the symmetry of M and Lambda (and of a batch's H).
SYMMETRY_RTOL = 1e-9
#: Lambda may have eigenvalues down to minus this (relative to its largest entry).
PSD_RTOL = 1e-12
#: Largest magnitude of a finite number in a problem (bounds may also be +-inf).
#: Far beyond any quantity of a robot in SI units, and small enough that the
#: solvers cannot overflow: squares stay below 1e24, ``det(J J^T)`` of a task of
#: up to 11 rows and 200 joints stays finite, and HiGHS (which refuses matrix
#: entries above 1e15 and reads bounds from 1e20 on as infinite) still solves.
MAX_MAGNITUDE = 1e12
#: Shortest control period [s] a step takes (:func:`lpik.limits.control_period`): no control
#: loop runs faster than a nanosecond, and the acceleration limits' share of a step
#: (``qdd_max dt^2``) stays far from the smallest double. With ``dt = 1e-200`` s, ``dt^2``
#: was 0: the compiled step read a robot at rest as outside its velocity limits, the
#: numpy path did not.
MIN_DT = 1e-9
#: Longest control period [s] the command line takes (``lpik simulate``, ``lpik map``): a
#: period above a second is no control loop, and the step bounds (velocity limits times
#: dt) stay far within :data:`MAX_MAGNITUDE`.
MAX_DT = 1.0

# ----------------------------------------------------------------- targets
#: A rotation target R (or a pose's rotation part) must have max |R^T R - I| at
#: most this and det(R) > 0; a pose's bottom row must be (0, 0, 0, 1) within it.
#: Loose enough for rotations rounded to float32 (about 1e-7), tight enough that
#: the numpy and compiled paths read the same rotation.
ROTATION_TOL = 1e-6

# ----------------------------------------------------- the independent check
#: Absolute tolerance of the check on bounds and rows, scaled by ``max(1, |bound|)``.
FEASIBILITY_TOL = 1e-7
#: Tolerance of the check on ``J dq = p dw``, relative to ``|J| |dq| + |dw|``.
EQUALITY_RTOL = 1e-7

#: A joint step [rad] of at most this is rounding, not motion, for the memory that feeds a
#: target's motion forward: after a step that moved no joint further the next step gets
#: none (:func:`lpik.command.moved_beyond_rounding`; whether a step is solved around the
#: motion still tests ``q_prev != q0`` exactly). Asked for the pose the arm already holds,
#: the compiled step moves the Panda's joints by 2e-16 rad (its kinematics round apart
#: from numpy's) and the numpy path not at all; with an exact test the next step fed the
#: target's motion forward on the compiled engine only, and the engines parted by 3e-7 rad
#: (tests/test_target_motion.py). 1e-10 rad per step is 1e-7 rad/s at 1 kHz: no drive
#: moves that slowly.
REST_STEP = 1e-10

# ---------------------------------------------------------- affine dexterity
#: p at or above this counts as the full displacement (no binding limit).
FULL_P = 1.0 - 1e-9
#: Ho's LP past the full displacement (:func:`lpik.methods.l1.l1`) takes its least-L1 step
#: among those with ``p`` within this below LP1's largest: a margin for the solver's
#: rounding of that largest ``p``, so that the second LP is feasible. The same margin in
#: the compiled form (:func:`lpik.fast.progress.least_l1_in_state`).
SCALED_P_MARGIN = 1e-9
#: A step solved around the motion (:mod:`lpik.continuation`) with ``p`` at or below this
#: changes the motion toward the command by nothing but rounding: it is the controlled stop.
NO_CHANGE_P = 1e-9

# -------------------------------------------------------- LP2's ratio test
#: Above this condition number of the Schur complement ``J H^-1 J^T`` (bounded from
#: above through its Cholesky factor by :func:`lpik.methods.kkt.ill_conditioned`, alike
#: on every path) the ratio test hands over to LP2's singular path
#: (:mod:`lpik.methods.singular`).
MAX_SCHUR_CONDITION = 1e10
#: LP2 with saturation (:mod:`lpik.methods.lp2s`) stops its passes where the next one's
#: Schur complement (over the joints still free) has a condition above this, the same
#: bound as :data:`MAX_SCHUR_CONDITION`. Such a pass gains a sliver of ``p`` by racing
#: the last free joints across their bounds, and rounding of the order of this times
#: the machine epsilon breaks ``J dq = p dw``: at 1e8 it stays within 1e-7 of ``|dw|``.
SATURATION_MAX_CONDITION = 1e8
#: LP2 with saturation takes a later pass only where the joint motion it adds per unit of
#: task motion it gains, ``|dq' - dq| / ((p' - p) |dw|)``, is at most this many times that of
#: the step so far, ``|dq| / (p |dw|)``. A pass through a nearly singular free-joint system
#: gains a sliver of ``p`` for a large null-space swing, and whether it is taken flips from
#: step to step (quality suite, scenario 4: +0.1 % of ``p`` for 2 rad/s on four joints).
SATURATION_MAX_PRICE = 10.0
#: On LP2's singular path, a singular value of ``J L^-T`` (``H = L L^T``) at or below this
#: share of the largest counts as 0 (``J`` has the lower rank; what is left is rounding).
#: Above it the decomposition solves eq. 18 exactly, however ill-conditioned. The same
#: share of the largest is the rounding of a change of ``sigma_min`` from one step to
#: the next (:func:`lpik.methods.autobound.singular_steps`).
SINGULAR_RTOL = 1e-12
#: A singular value of LP2's singular path, or a diagonal of the Schur complement's
#: Cholesky factor (:func:`lpik.methods.kkt.ill_conditioned`), at or below this counts as
#: 0 whatever the largest is: its square, which LP2 divides by, would not be a normal
#: double (``sqrt`` of the smallest, 2.2e-308). A Jacobian of entries near 1e-300
#: otherwise gave a non-finite step (``check_failed``) where the task cannot move.
SINGULAR_FLOOR = 1.4916681462400413e-154
#: A slack below zero by at most this (relative to the bound) counts as zero.
SLACK_TOL = 1e-12
#: A rate ``|b|`` at or below this (relative to the largest rate) counts as zero.
RATE_TOL = 1e-14
#: The feasible interval of p may be empty by at most this and still count as a point.
INTERVAL_TOL = 1e-12
#: At most this share of the room between LP2's step at p = 0 and a joint's bounds goes
#: to sec. 3.1's pull towards q_ref; the rest is left for the command.
SMOOTHING_SHARE = 0.5
#: A joint's share of that pull at or below this (relative to the largest, at least 1) counts
#: as none: it is the rounding of a zero (a pinned joint's coupling), which must not decide
#: how much of the pull the step takes (:func:`lpik.methods.pull.pull_room`), as long as
#: it does not carry the joint past a bound it sits at (beyond :data:`SLACK_TOL`).
PULL_TOL = 1e-10

# ---------------------------------------------------- stalls and the progress step
#: A step can stall only when it follows at most this share of its command (``p``);
#: above it the exact step stands without a look at the progress step.
STALL_P = 1e-2
#: A step with ``p <= STALL_P`` that an acceleration limit does not hold stalls when it
#: reduces the L1 task error by less than this share of what the progress step (the
#: least error within the same limits) achieves (:func:`lpik.methods.progress.is_stall`).
STALL_SHARE = 0.5
#: Below this ``sigma_min / sigma_max`` of the task Jacobian a configuration counts as near a
#: singular one: the automatic multiplier bound acts there (its default ``activation``,
#: :class:`lpik.limits.AutomaticMultiplierBounds`), and there only, without acceleration
#: limits, may an exact step with ``0 < p <= STALL_P`` held by a velocity limit stall
#: (:func:`lpik.methods.progress.at_speed`, certified by
#: :func:`lpik.methods.autobound.clearly_regular`). Away from singular configurations such
#: a step follows the command as fast as the joints allow, and ``p`` is small only because
#: the command asks for more than a step can do (a target jump with the clamp off,
#: ``V = error / dt``). Measured on the quality suite's scenario 4 on the iiwa14
#: (``--robot iiwa14``, ``sigma_min / sigma_max`` 0.066 to 0.087): judged by the gains alone
#: the progress step (every joint at its limit, twice the exact step's gain) took over
#: half the steps, jitter 366 rad/s against Drake's 243. Near a singular configuration the
#: same limit holds a direction that costs ever more joint motion (the Panda unfolding from
#: a stretched pose in scenario 2 at 0.0018, the iiwa14 at 0.01 to 0.05), and the stall
#: stage stays: a rule on the step's own direction instead (``|J dq| >= 0.01 |J|_F
#: |dq|``) let the iiwa14's exact steps fold its elbow at its velocity limit while the target
#: came back, 98 mm of position error RMS in reach against 29 (legs +-y).
SINGULAR_ACTIVATION = 5e-2
#: Once the stall stage has taken the progress step, and where no acceleration limit
#: bounds the change of the joint velocities, the next step still stalls while the exact
#: step gains less than this share of the progress step (a band above STALL_SHARE:
#: without it the steps flip between the two laws, every flip a jump of the joint
#: velocities; on the quality suite's scenario 2 those flips were 80% of the jitter, and
#: the band cut it from 1,394 rad/s to 930). A band for ``p`` as well (up to 0.05) cut it
#: to 480 but held an arm pushed beyond reach back from coming home.
STALL_KEEP_SHARE = 1.0
#: Two L1 gains (the exact and the progress step's) within this times the command's
#: scale (``max(1, max |dw|)``) are a tie, rounding: the step does not stall, so that a
#: progress step that is the exact step itself keeps the exact step's status on every
#: path (the compiled and numpy paths sum the errors in another order).
GAIN_RTOL = 1e-12
#: After a progress step, where no acceleration limit bounds the change of the joint
#: velocities (the band of STALL_KEEP_SHARE), a step with ``STALL_P < p <= STALL_BLEND_P``
#: may stall too, and a stalled step there is not the progress step alone but
#: ``w dq_exact + (1 - w) dq_progress``, the exact step's weight ``w`` growing linearly
#: from 0 at ``STALL_P`` to 1 here (:func:`lpik.methods.progress.exact_weight`): the way
#: back to the exact step is continuous in ``p``. With the switch at ``STALL_P`` alone,
#: four progress steps lifted a joint off its end-stop, the fifth was an exact step with
#: ``p = 0.012`` that drove it back, a cycle of two jumps of 4.6 rad/s (the quality
#: suite's scenario 2, leg -x: 480 rad/s of jitter, 36 with the blend; the whole
#: scenario 924 and 480, every excursion recovered). Under acceleration limits the
#: limits bound those jumps and the switch stays at ``STALL_P``: there the blend gave
#: scenario 8's third move 29 mm of overshoot against 2.9. Without a progress step
#: before it, an exact step with ``p`` up to here is not weighed against the progress LP
#: (on scenario 4's step inputs that cost a median 32 us per step against 11).
STALL_BLEND_P = 2e-2
#: Weight of the joint motion ``sum |dq_i|`` against the task error in the progress step
#: (:mod:`lpik.methods.progress`) and in the fading motion's stop (:mod:`lpik.continuation`)
#: [m (or rad) of error per rad of motion]: a joint moves only where each radian buys at
#: least 1 cm (10 mrad) less error. Where the error can hardly shrink (a target beyond
#: reach) the LP's optimum otherwise jumps between vertices, the joints at their velocity
#: limits one way and then the other: at 1e-6 the quality suite's scenario 2 with the
#: stage on had a joint-velocity jitter of 26,440 rad/s, at 1e-2 3,207 (strict: 447).
#: Near a singular configuration a radian buys about ``sigma_min`` of error, at the
#: automatic multiplier bound's floor less than 1 cm, so a goal there is not crept up to
#: (``benchmarks/random_goals.py``: Panda goals 5 and 12 end 0.09 and 0.64 mm off). At 1e-4
#: goal 12 is reached and goal 5 ends 0.028 mm off, but the quality suite's scenario 2 had
#: 8,890 frozen steps against 297 (position error RMS 346 mm against 126) and scenario
#: 11's jitter rose from 620 to 743 rad/s: not kept. Scaled down with the error below 1 cm
#: (``min(MOTION_WEIGHT, |target|_1)`` per radian) it reached goal 5 (Panda 24 and 25 of
#: 30, with and without acceleration limits) but raised the acceleration reversals by 23 %
#: (Panda) and 33 % (iiwa): not kept. Goal 12 and the iiwa's goal 16 are not a matter of
#: this weight: the error left (0.6 mm) lies along the singular direction, the
#: least-squares step towards the goal first lowers ``sigma_min`` (the goal is across the
#: singular configuration), and the self-motion changes it by under 0.1 % (the iiwa).
MOTION_WEIGHT = 1e-2
#: Under acceleration limits the progress step's motion term is measured from the arm's
#: motion (coasting is free), but from the braking step where that motion carries the
#: task away from the command: where the cosine between ``J (q0 - q_prev)`` and ``dw`` is
#: below minus this (:func:`lpik.methods.progress.progress_center`). Coasting at an angle
#: of little over 90 degrees can still pay in the step's L1 error while it lengthens the
#: Euclidean one: on the iiwa14's random goal 3, with joint 7 on its end-stop, the tool
#: drifted 13 mm away from the goal in 1 s of progress steps, each 0.002 mm better in L1.
#: Braking at every angle above 90 degrees (0 here) stopped the drift but, braking and
#: then speeding up again, raised that goal's acceleration reversals from 151 to 253;
#: from 120 degrees on (0.5) the reversals stayed 154 and the drift fell from 518 to 150
#: steps of growing error. The same test says when an exact step with ``p <= STALL_P``
#: held by a joint's bound (not an acceleration limit or a row) drifts, and stalls
#: (:func:`lpik.methods.progress.drifts`).
COASTING_DRIFT_COSINE = 0.5
#: Under acceleration limits, a step held by an acceleration limit while the arm's last
#: motion carries the tool along the command (``J last`` within this cosine of ``dw``'s
#: direction, about 8 degrees) keeps its direction: it speeds up (or slows down) as fast
#: as the arm can, and the stall stage leaves it as it leaves a start from rest
#: (:func:`lpik.methods.progress.moves_along`).
ALONG_COMMAND_COSINE = 0.99
#: After a progress step, the way each joint left the center in the arm's last step is
#: cheaper by this share of ``MOTION_WEIGHT`` (times its share of the largest deviation:
#: :func:`lpik.methods.progress.motion_prices`), so that two nearly tied vertices of the
#: progress LP do not take turns at every step. The observed swing of their objectives was
#: 1e-7, against 1.5e-6 that this share gives a deviation of 0.6 mrad per step.
MOTION_KEEP_SHARE = 0.25
#: ... where the last step left the center by more than this share of the motion: a
#: deviation of 1e-12 rad (the last step was the exact step, up to rounding) once made
#: every price a random share of the bias (a parity test between two kinematics backends).
MOTION_KEEP_RTOL = 1e-6
#: Under acceleration limits a joint moving towards the stop ahead of a motion that stops
#: paying (:func:`lpik.bands.fading_band`) does not speed up towards it once it could not
#: keep its speed were that stop this share of its distance away (within about twice its
#: braking distance): it coasts or slows down. Without it the exact step sped the joints up
#: at their limits for p ~ 0.0015 until the stop pinned three of them to full braking,
#: p fell to 0 and the progress step braked for 5 to 8 steps, over and over (the quality
#: suite's scenario 10, leg +y: 67 of its 137 rad/s of jitter on 1,530 changes of law).
#: Measured against no such rule: scenario 10's jitter 384 -> 218 rad/s (Drake with the
#: same limits 349), orientation error RMS 7.3 -> 0.9 mrad; excursions under acceleration
#: limits (benchmarks/excursions.py) 69, 70 and 69 of 70 (Panda, UR5e, iiwa; 68, 70, 70);
#: random goals with them 24, 25 and 26 of 30 (24, 25, 25) with 2,059, 1,340 and 890
#: acceleration reversals (1,917, 3,438, 1,545); scenario 11's jitter 620 -> 626. At 0.25:
#: scenario 10 187 rad/s, but scenario 11 651 (more changes of law near the goals). The
#: stop before a singular configuration keeps its own rule (the floor's row).
FADING_HOLD_SHARE = 0.5
#: Where the arm's motion has reached the automatic multiplier bound's floor under
#: acceleration limits, the stall stage's progress step may take ``sigma_min / sigma_max``
#: below the floor only as fast as from the floor to 0 in this time [s]
#: (:func:`lpik.methods.autobound.floor_row`). Measured with ``benchmarks/random_goals.py``
#: and ``benchmarks/excursions.py``: at the bound's approach time (0.05 s) two stretched
#: excursions folded past their pose of greatest reach (57 of 60 recovered, against 59);
#: with no creep at all (``inf``) the UR5e's goals 0, 4, 12 and 25 had 2,591 reversals
#: against 1,548 at 1 s.
FLOOR_CREEP_TIME = 1.0
#: The automatic bound's probe (step 2: does ``sigma_min`` grow along the step?) decides
#: from ``J_probe J_probe^T`` shifted by ``(sigma_min (1 +- share))^2``, two Cholesky
#: tests instead of a singular value decomposition, where ``share`` = this times
#: :data:`MACHINE_EPSILON` times ``(sigma_max / sigma_min)^2`` lies far beyond the Gram matrix's
#: rounding (about 2 (m + n) eps sigma_max^2 in its eigenvalues), and at most
#: :data:`PROBE_GRAM_MAX_SHARE`; a change of ``sigma_min`` within the share goes to the SVD.
PROBE_GRAM_SAFETY = 1e3
#: See :data:`PROBE_GRAM_SAFETY`: the largest share (``sigma_min`` at about 5e-4 of
#: ``sigma_max``); nearer a singular configuration the SVD decides.
PROBE_GRAM_MAX_SHARE = 1e-6
#: The compiled progress LP's simplex: a pivot entry of at most this size is not taken.
SIMPLEX_PIVOT_TOL = 1e-11
#: The compiled progress LP's simplex: a reduced cost beyond minus this improves the step
#: (the costs are 1 per task row and ``MOTION_WEIGHT`` per joint).
SIMPLEX_COST_TOL = 1e-13

# ----------------------------------------------------- binding from the duals
#: A limit within this (relative to its size) of its bound is active.
ACTIVE_RTOL = 1e-9
#: Duals all at or below this cannot tell which limit binds.
DUAL_TOL = 1e-9
#: Relative amount by which active limits are relaxed to find the binding one.
RELAX = 1e-6
#: Relaxing by RELAX times these in turn: near a singularity a limit that holds p may
#: raise it by only 1e-4 of its relaxation, within the solver's rounding at RELAX alone.
RELAX_SCALES = (1.0, 1e3)
#: p must rise by more than this share of RELAX for a relaxation to have raised it.
RELAX_GAIN = 1e-3

# -------------------------------------------------------- classical methods
#: Above this condition number the classical linear systems count as singular.
MAX_CONDITION = 1e12

# ------------------------------------------------------------------- the NLP
#: Tolerance handed to SLSQP.
SLSQP_TOL = 1e-12
#: Largest accepted residual of the nonlinear constraint (eq. 10) [m or rad].
NONLINEAR_TOL = 1e-7
