"""Fits an odometry accuracy class (the filter's rot1-trans-rot2 motion noise, alpha1..alpha4) to a bag's odometry
against its reference path: the logic of ``calibrate_odometry`` (USAGE, below, is the user's help).

The model is the filter's (src/core/particle_filter.cpp, trunk_slam_pipeline.cpp): the odometry between two
updates is cut into steps along its own samples (a step ends at the first sample that is motion_step metres or
motion_step_angle radians (|rot1| + |rot2|) from the step's start), each step is decomposed into (rot1, trans,
rot2) and gets independent Gaussian noise of standard deviations

    sigma_rot1 = alpha1 |rot1| + alpha2 trans,   sigma_trans = alpha3 trans + alpha4 (|rot1| + |rot2|),
    sigma_rot2 = alpha1 |rot2| + alpha2 trans.

A step cut short (the last one before an update, or a window's end) carries its share of a full step's variance
(the variances add up as a random walk: its standard deviations are divided by the square root of its share of
motion_step or motion_step_angle, as partialStepNoiseScale in the filter).

With ``--motion-model velocity`` (odometry that is commanded velocities integrated) the model is the filter's
velocity model (applyVelocityBlock): the odometry's samples are arcs, cut into blocks of motion_noise_time seconds;
per block one error of the distance, alpha3 D + alpha4 A, and one of the turn, alpha1 A + alpha2 D (D, A: the
block's distance and turning), spread over its arcs in proportion; the windows' error variances are again linear
in the same six monomials (``window_blocks``).

The drive is cut into non-overlapping windows whose ends are reference stamps; each window's odometry (the poses
interpolated at its ends, its samples in between) is cut into steps as the filter does, and the errors of the
window (reference against odometry) get a variance that is linear in (alpha1^2, alpha1 alpha2, alpha2^2, alpha3^2,
alpha3 alpha4, alpha4^2), to first order in the noise (``window_steps``, ``_observations``). The alphas are the
maximum of the Gaussian likelihood of all errors, taken as independent with these variances (``fit``).
"""
import argparse
import math
import os
import shlex
import sys

import numpy as np

from rbpf_slam import atomic, evaluate as ev
from rbpf_slam.atomic import UserError

PROG = 'calibrate_odometry'
#: The command's help (``calibrate_odometry --help``).
USAGE = """\
Estimates an odometry accuracy class (the filter's rot1-trans-rot2 motion noise alpha1..alpha4) from a bag with
odometry and a reference path, and prints it as YAML in the style of config/odometry/*.yaml.

  rosrun rbpf_slam calibrate_odometry BAG [--odom TOPIC] [--reference TOPIC] [--motion-step M]
      [--motion-step-angle RAD] [--window M] [-o FILE.yaml] [--name TEXT] [-q]

The odometry is nav_msgs/Odometry on --odom (default /odom). The reference is any path evaluate_bag_run reads
(nav_msgs/Odometry, PoseStamped, PoseWithCovarianceStamped, PointStamped, or NavSatFix converted to a local
east-north plane); without --reference the first of /ground_truth/odom, /gps/fix, /gps, /fix in the bag (else its
only NavSatFix topic), as evaluate_bag_run picks it. A reference whose orientation is missing (all zero) or the
same throughout (a GPS written as Odometry) is taken as positions only.

The filter cuts the odometry between two updates into steps along its own samples (a step ends at the first
sample motion_step metres or motion_step_angle radians (|rot1| + |rot2|) from its start) and gives each step
independent Gaussian noise:
  sigma_rot1 = alpha1 |rot1| + alpha2 trans,  sigma_trans = alpha3 trans + alpha4 (|rot1| + |rot2|),
  sigma_rot2 = alpha1 |rot2| + alpha2 trans.
Pass the motion_step and motion_step_angle the class is for (default 0.2 m, 0.2 rad; a car: 0.5, 0.2): the
alphas belong to them.

The drive is cut into non-overlapping windows of --window metres of odometry travel (default 1 m with a
reference that has headings; 10 m with one of positions only, there alternately 10 and 20 m, so that the
reference's own noise, the same in every window, is told from the odometry's, which grows with the window).
Windows end at reference stamps (the odometry is interpolated there) and are cut by the odometry's travel, not the
reference's: the model is the truth given the odometry, and a noisy reference's own travel would bias the
distances. Each window's odometry is cut into the filter's steps, which gives the predicted variance of its errors
as a function of the alphas (to first order in the noise):
  * reference with headings: the heading change error wrap(dtheta_ref - dtheta_odo) (the sum over the steps of
    sigma_rot1^2 + sigma_rot2^2) and the distance error |dp_ref| - |dp_odo| (sigma_trans^2 along the chord, plus
    the lateral shift of the rest of the window by each step's rot noise); no noise of the reference;
  * positions only: the distance error, and the error of the course change between two consecutive windows' chords
    (the heading noise of the first window, less its own chord's turn, plus the second's chord's turn), each plus
    the reference's own noise: from the NavSatFix covariance where every fix states one, else a free parameter
    sigma_ref (per axis, independent per fix), fitted and reported.
The alphas (>= 0) maximise the Gaussian likelihood of all errors, taken as independent (exact between windows with
headings; it leaves out the heading-distance correlation within a window and the shared fixes of neighbouring
GPS windows). A position-only reference pins alpha1 and alpha2 (from the course changes) and the sum of the
distance noise, but only loosely how alpha3, alpha4 and sigma_ref share it: see their standard errors.

The output is the class: comments saying what it is, the command that made it and the fit (windows, metres and
radians driven, the mean errors -- a distance scale error and a heading drift per metre, biases that the class
takes as noise --, the alphas with approximate standard errors, and the share of errors inside the fitted model's
95 % interval, which should be about 95 %), then motion: {alpha1 .. alpha4} (3 significant digits), motion_step and
motion_step_angle. Printed on stdout, and with -o written to FILE atomically.

Refused, with one line on stderr, exit code 1 and no file written: a bag that is missing or not readable, no
odometry topic, no reference (the line names the topics looked for and those in the bag), odometry and reference
not overlapping in time, fewer than 20 windows or less than 10 windows' length of reference travel, and less than
one full turn (2 pi rad) in total, without which alpha1 and alpha4 (the noise from turning) cannot be fitted.
"""
ODOMETRY_TYPE = 'nav_msgs/Odometry'
#: Fewer windows than this are refused (four alphas, and a check of 95 % coverage, need more).
MIN_WINDOWS = 20
#: The reference must move at least this many windows' lengths in total.
MIN_TRAVEL_WINDOWS = 10
#: Total turning [rad] (sum of |rot1| + |rot2| of the odometry's steps in the windows) below which alpha1 and
#: alpha4 (the noise from turning) cannot be told from the rest: refused.
MIN_TURN = 2.0 * math.pi
#: Default window [m of odometry travel] with a reference that has headings, and with a position-only one.
WINDOW_POSES = 1.0
WINDOW_POSITIONS = 10.0
#: A window's distance error counts only where its odometry chord is at least this share of the window (a
#: window that drives round a corner back to near its start has a chord length that is not linear in the noise).
MIN_CHORD_SHARE = 0.5
#: A window whose odometry travel exceeds its length by more than this share spans a gap of the reference (no
#: stamp where it should have ended): it is left out, and so are the course changes to and from it.
MAX_WINDOW_OVERSHOOT = 0.5
#: Variance floor [rad^2, m^2] (a window without motion has no predicted noise at all).
VARIANCE_FLOOR = 1e-12
#: Below this step length the filter takes the motion as a turn on the spot (decomposeOdometry).
TURN_ON_SPOT = 0.01
#: z of the two-sided 95 % interval of a Gaussian.
Z95 = 1.959963984540054


def wrap(a):
    """Angles into [-pi, pi)."""
    return (np.asarray(a, float) + math.pi) % (2.0 * math.pi) - math.pi


def _wrap1(a):
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def decompose(a, b):
    """(rot1, trans, rot2) of the motion from pose a to pose b (x, y, theta), as decomposeOdometry."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    trans = math.hypot(dx, dy)
    rot1 = 0.0 if trans < TURN_ON_SPOT else _wrap1(math.atan2(dy, dx) - a[2])
    return rot1, trans, _wrap1(b[2] - a[2] - rot1)


def cut_steps(poses, step, step_angle):
    """Indices into ``poses`` (n, 3: x, y, theta) of the ends of the filter's steps from poses[0] to poses[-1]:
    a step ends at the first pose whose motion from the step's start is >= ``step`` [m] or whose |rot1| + |rot2|
    is >= ``step_angle`` [rad]; the rest up to the last pose is the last step (as trunk_slam_pipeline.cpp
    predicts the motion up to an update). Returns [0, ..., n - 1] (the last pose once)."""
    ends = [0]
    start = 0
    n = len(poses)
    for i in range(1, n):
        r1, t, r2 = decompose(poses[start], poses[i])
        if t >= step or abs(r1) + abs(r2) >= step_angle:
            ends.append(i)
            start = i
    if ends[-1] != n - 1:
        ends.append(n - 1)
    return ends


def _r90(w):
    return np.column_stack([-w[:, 1], w[:, 0]])


def window_steps(poses, step, step_angle):
    """The steps of one window (poses (n, 3), its odometry from its start to its end) and the coefficients of its
    errors' variances. Returns a dict:

    * ``steps``: (S, 3) rot1, trans, rot2; ``turn``: sum of |rot1| + |rot2|; ``travel``: sum of trans;
    * ``g_r1``, ``g_r2``, ``g_t`` (S, 6): each step's noise variances as rows over the monomials
      (a1^2, a1 a2, a2^2, a3^2, a3 a4, a4^2) (sigma_rot1^2 = g_r1 . m, ...);
    * ``heading``: the row of the variance of the heading change (the sum of all rot noise);
    * ``chord`` (2,): the end's position relative to the start; ``distance``: the row of the variance of the
      chord's length, to first order (the trans noise along the chord, and the lateral shift of the rest of the
      window by each rot noise: rotating the path after a step's start about it);
    * ``direction_here``, ``direction_before``: rows of the variance of the error of the chord's direction
      change from the previous window's chord (the noise of this window's steps as it enters this window's
      direction (local) and, when this window is the previous one, the next direction (its heading change less
      its local direction)).
    """
    ends = cut_steps(poses, step, step_angle)
    b = poses[ends]
    s = len(b) - 1
    zero = np.zeros((0, 6))
    out = {'steps': np.zeros((0, 3)), 'turn': 0.0, 'travel': 0.0, 'g_r1': zero, 'g_r2': zero, 'g_t': zero,
           'heading': np.zeros(6), 'distance': np.zeros(6), 'direction_here': np.zeros(6),
           'direction_before': np.zeros(6), 'chord': poses[-1, :2] - poses[0, :2]}
    if s == 0:
        return out
    u = np.array([decompose(b[k], b[k + 1]) for k in range(s)])
    r1, t, r2 = np.abs(u[:, 0]), u[:, 1], np.abs(u[:, 2])
    zeros = np.zeros(s)
    g_r1 = np.column_stack([r1 ** 2, 2 * r1 * t, t ** 2, zeros, zeros, zeros])
    g_r2 = np.column_stack([r2 ** 2, 2 * r2 * t, t ** 2, zeros, zeros, zeros])
    g_t = np.column_stack([zeros, zeros, zeros, t ** 2, 2 * t * (r1 + r2), (r1 + r2) ** 2])
    # The last step, cut short by the window's end, carries its share of a full step's variance.
    share = max(t[-1] / step, (r1[-1] + r2[-1]) / step_angle)
    if 0.0 < share < 1.0:
        g_r1[-1] /= share
        g_r2[-1] /= share
        g_t[-1] /= share
    p = b[:, :2]
    chord = p[-1] - p[0]
    length = float(np.hypot(*chord))
    heading_dir = b[:-1, 2] + u[:, 0]  # the direction each step's translation goes
    e = np.column_stack([np.cos(heading_dir), np.sin(heading_dir)])
    out.update(steps=u, turn=float(np.sum(r1 + r2)), travel=float(np.sum(t)), g_r1=g_r1, g_r2=g_r2, g_t=g_t,
               heading=np.sum(g_r1 + g_r2, axis=0), chord=chord)
    if length > 0:
        uc = chord / length
        nc = np.array([-uc[1], uc[0]])
        rest1 = p[-1] - p[:-1]  # from each step's start to the end (rot1 turns this)
        rest2 = p[-1] - p[1:]  # from each step's end to the end (rot2 turns this)
        ct, cr1, cr2 = e @ uc, _r90(rest1) @ uc, _r90(rest2) @ uc
        out['distance'] = (ct ** 2) @ g_t + (cr1 ** 2) @ g_r1 + (cr2 ** 2) @ g_r2
        dt, dr1, dr2 = (e @ nc) / length, (rest1 @ uc) / length, (rest2 @ uc) / length
        out['direction_here'] = (dt ** 2) @ g_t + (dr1 ** 2) @ g_r1 + (dr2 ** 2) @ g_r2
        out['direction_before'] = (dt ** 2) @ g_t + ((1 - dr1) ** 2) @ g_r1 + ((1 - dr2) ** 2) @ g_r2
    return out


def arcs(poses):
    """Per pair of consecutive poses (n, 3) the arc a unicycle drives between them (as arcStep in the filter):
    (distance (negative backwards), turn, start x, start y, end heading); (n - 1, 5)."""
    out = np.zeros((max(len(poses) - 1, 0), 5))
    for k in range(len(poses) - 1):
        a, b = poses[k], poses[k + 1]
        dx, dy = b[0] - a[0], b[1] - a[1]
        c, s = math.cos(a[2]), math.sin(a[2])
        lx, ly = c * dx + s * dy, -s * dx + c * dy
        turn = _wrap1(b[2] - a[2])
        chord = math.hypot(lx, ly)
        half = 0.5 * turn
        ratio = 1.0 + half * half / 6.0 if abs(half) < 1e-4 else half / math.sin(half)
        dist = 0.0 if chord < 1e-9 else (1.0 if lx >= 0 else -1.0) * chord * ratio
        out[k] = (dist, turn, a[0], a[1], b[2])
    return out


def window_blocks(poses, stamps, block_time):
    """As ``window_steps`` for the velocity model: the window's arcs (between its poses, (n, 3), at ``stamps``)
    cut into blocks of ``block_time`` seconds (a block ends at the first sample at least block_time after its
    start; the last, shorter one carries its share of the variance). Per block, one error of the distance (along
    each arc's end heading, in proportion to alpha3 |d| + alpha4 |t| of the arc) and one of the turn (the rest of
    the path rotated about each arc's middle, in proportion to alpha1 |t| + alpha2 |d|)."""
    a = arcs(poses)
    zero = np.zeros(6)
    out = {'steps': np.zeros((0, 3)), 'turn': 0.0, 'travel': 0.0, 'heading': zero.copy(), 'distance': zero.copy(),
           'direction_here': zero.copy(), 'direction_before': zero.copy(), 'chord': poses[-1, :2] - poses[0, :2]}
    if not len(a):
        return out
    d, t = np.abs(a[:, 0]), np.abs(a[:, 1])
    blocks, start = [], 0
    for k in range(len(a)):
        if stamps[k + 1] - stamps[start] >= block_time or k == len(a) - 1:
            blocks.append((start, k + 1, (stamps[k + 1] - stamps[start]) / block_time))
            start = k + 1
    chord = out['chord']
    length = float(np.hypot(*chord))
    e = np.column_stack([np.cos(a[:, 4]), np.sin(a[:, 4])])
    mid = 0.5 * (poses[:-1, :2] + poses[1:, :2])
    rest = poses[-1, :2] - mid
    if length > 0:
        uc = chord / length
        nc = np.array([-uc[1], uc[0]])
        ct, cr = e @ uc, _r90(rest) @ uc  # chord length per unit of distance / turn error of each arc
        dt, dr = (e @ nc) / length, (rest @ uc) / length  # chord direction per unit ...
    else:
        ct = cr = dt = dr = np.zeros(len(a))

    def rows(sl, w, share):
        """The variance rows of a block's (slice ``sl`` of the arcs) turn error, alpha1 sum(|t| w) + alpha2
        sum(|d| w), and distance error, alpha3 sum(|d| w) + alpha4 sum(|t| w), for per-arc weights ``w``."""
        x, y = float(np.sum(t[sl] * w[sl])), float(np.sum(d[sl] * w[sl]))
        return np.array([x * x, 2 * x * y, y * y, 0, 0, 0]) / share, np.array([0, 0, 0, y * y, 2 * x * y, x * x]) / share

    one = np.ones(len(a))
    for i, j, share in blocks:
        sl, share = slice(i, j), (share if 0.0 < share < 1.0 else 1.0)
        out['heading'] = out['heading'] + rows(sl, one, share)[0]
        if length > 0:
            out['distance'] = out['distance'] + rows(sl, ct, share)[1] + rows(sl, cr, share)[0]
            out['direction_here'] = out['direction_here'] + rows(sl, dt, share)[1] + rows(sl, dr, share)[0]
            out['direction_before'] = out['direction_before'] + rows(sl, dt, share)[1] + rows(sl, 1 - dr, share)[0]
    out.update(steps=np.zeros((len(blocks), 3)), turn=float(np.sum(t)), travel=float(np.sum(d)))
    return out


def cut_windows(travel, window, alternate=False):
    """Indices of window ends into the reference stamps whose odometry travel (cumulative [m], not
    decreasing) is ``travel``: each window ends at the first stamp at least ``window`` metres after its start
    (with ``alternate``, windows of window and 2 window metres by turns)."""
    ends = [0]
    k = 0
    while True:
        length = window * (2.0 if alternate and k % 2 else 1.0)
        j = int(np.searchsorted(travel, travel[ends[-1]] + length - 1e-9, side='left'))
        if j >= len(travel):
            break
        ends.append(max(j, ends[-1] + 1))
        k += 1
    return ends


def _monomials(a):
    a1, a2, a3, a4 = a
    return np.array([a1 * a1, a1 * a2, a2 * a2, a3 * a3, a3 * a4, a4 * a4])


def _monomial_jacobian(a):
    a1, a2, a3, a4 = a
    return np.array([[2 * a1, a2, 0, 0, 0, 0], [0, a1, 2 * a2, 0, 0, 0],
                     [0, 0, 0, 2 * a3, a4, 0], [0, 0, 0, 0, a3, 2 * a4]], dtype=float)  # (4, 6): d m / d a


def variances(obs, params):
    """Predicted variances of the observations (``A`` (n, 6), ``B`` (n,) per unit reference variance,
    ``C`` (n,) known) for params (a1..a4[, sigma_ref])."""
    v = obs['A'] @ _monomials(params[:4]) + obs['C'] + VARIANCE_FLOOR
    if len(params) > 4:
        v = v + obs['B'] * params[4] ** 2
    return v


def _nll(params, obs):
    v = variances(obs, params)
    e2 = obs['e'] ** 2
    value = 0.5 * float(np.sum(e2 / v + np.log(v)))
    dv = 0.5 * (1.0 / v - e2 / v ** 2)
    grad = _monomial_jacobian(params[:4]) @ (obs['A'].T @ dv)
    if len(params) > 4:
        grad = np.r_[grad, 2.0 * params[4] * float(obs['B'] @ dv)]
    return value, grad


def fit(obs, free_reference=False, seed=0):
    """Maximum likelihood alphas (and sigma_ref with ``free_reference``) of the observations: L-BFGS-B over
    alphas >= 0 from several starts (the likelihood is flat at alpha = 0, so no start is there). Returns
    (params, negative log-likelihood, standard errors (nan where not defined: at the bound, or a singular
    curvature))."""
    from scipy.optimize import minimize
    rng = np.random.RandomState(seed)
    starts = [[0.05, 0.02, 0.02, 0.01], [0.2, 0.05, 0.05, 0.05], [0.02, 0.005, 0.005, 0.005]]
    starts += [list(10 ** rng.uniform(-2.5, -0.5, 4)) for _ in range(5)]
    scale = math.sqrt(max(float(np.median(obs['e'][obs['kind'] != 'heading'] ** 2))
                          if np.any(obs['kind'] != 'heading') else 1.0, 1e-6))
    best = None
    for s in starts:
        x0 = np.array(s + ([scale] if free_reference else []), dtype=float)
        bounds = [(0.0, None)] * len(x0)
        r = minimize(_nll, x0, args=(obs,), jac=True, method='L-BFGS-B', bounds=bounds,
                     options={'maxiter': 2000, 'ftol': 1e-13, 'gtol': 1e-10})
        if best is None or r.fun < best.fun:
            best = r
    x = np.maximum(best.x, 0.0)
    return x, float(best.fun), _standard_errors(x, obs)


def _standard_errors(x, obs):
    """Standard errors from the curvature of the negative log-likelihood (finite differences of its gradient)
    over the parameters that are off their bound; nan for the others. The errors are taken as independent,
    so these are approximate."""
    free = np.flatnonzero(x > 1e-6 * max(1.0, float(np.max(x))))
    se = np.full(len(x), np.nan)
    if not len(free):
        return se
    h = np.zeros((len(free), len(free)))
    for a, i in enumerate(free):
        d = 1e-4 * x[i]
        up, down = x.copy(), x.copy()
        up[i] += d
        down[i] -= d
        h[a] = (_nll(up, obs)[1][free] - _nll(down, obs)[1][free]) / (2 * d)
    h = 0.5 * (h + h.T)
    try:
        cov = np.linalg.inv(h)
    except np.linalg.LinAlgError:
        return se
    diag = np.diag(cov)
    se[free] = np.where(diag > 0, np.sqrt(np.abs(diag)), np.nan)
    return se


def _observations(windows, ref_xy, ref_yaw_unwrapped, odo_yaw_unwrapped, ref_var=None):
    """``windows``: consecutive windows (window_steps), None for one left out. The errors and their variance rows. With headings: per window the heading error and the distance error.
    Without: per window the distance error, and per pair of consecutive windows the error of the course change
    (the angle between their chords), each with the reference's own noise (isotropic, independent per fix:
    ``ref_var`` (per reference stamp) known, else the coefficient B of a free sigma_ref^2)."""
    e, kind, rows, b, c = [], [], [], [], []
    headings = ref_yaw_unwrapped is not None
    known = ref_var is not None

    def add(k, err, row, bcoef, terms):
        e.append(err)
        kind.append(k)
        rows.append(row)
        b.append(bcoef)
        c.append(sum(w * ref_var[j] for j, w in terms) if known else 0.0)

    for k, w in enumerate(windows):
        if w is None:
            continue
        i, j = w['start'], w['end']
        ref_chord = ref_xy[j] - ref_xy[i]
        length = float(np.hypot(*w['chord']))
        if headings:
            err = _wrap1((ref_yaw_unwrapped[j] - ref_yaw_unwrapped[i]) - (odo_yaw_unwrapped[j] - odo_yaw_unwrapped[i]))
            add('heading', err, w['heading'], 0.0, [])
        if length >= MIN_CHORD_SHARE * w['window']:
            add('distance', float(np.hypot(*ref_chord)) - length, w['distance'], 0.0 if headings else 2.0,
                [] if headings else [(i, 1.0), (j, 1.0)])
        if not headings and k > 0 and windows[k - 1] is not None:
            p = windows[k - 1]
            lp = float(np.hypot(*p['chord']))
            if lp < MIN_CHORD_SHARE * p['window'] or length < MIN_CHORD_SHARE * w['window']:
                continue
            ref_prev = ref_xy[p['end']] - ref_xy[p['start']]
            course_ref = math.atan2(ref_chord[1], ref_chord[0]) - math.atan2(ref_prev[1], ref_prev[0])
            course_odo = (math.atan2(w['chord'][1], w['chord'][0]) - math.atan2(p['chord'][1], p['chord'][0]))
            n1 = np.array([-w['chord'][1], w['chord'][0]]) / length ** 2  # normal / length
            n0 = np.array([-p['chord'][1], p['chord'][0]]) / lp ** 2
            mid = float(np.sum((n1 + n0) ** 2))
            add('course', _wrap1(course_ref - course_odo), p['direction_before'] + w['direction_here'],
                1.0 / length ** 2 + 1.0 / lp ** 2 + mid,
                [(j, 1.0 / length ** 2), (i, mid), (p['start'], 1.0 / lp ** 2)])
    n = len(e)
    return {'e': np.array(e, float), 'kind': np.array(kind, dtype=object).astype(str) if n else np.zeros(0, str),
            'A': np.array(rows, float).reshape(n, 6), 'B': np.array(b, float), 'C': np.array(c, float)}


def calibrate(odo, ref, motion_step, motion_step_angle, window=None, ref_var=None, free_reference=True,
              motion_noise_time=None):
    """Fit a class (the velocity model's with ``motion_noise_time`` [s], else the odometry model's). odo: (t, xy, yaw) of the odometry, sorted by stamp; ref: (t, xy, yaw or None) of the
    reference, sorted by stamp; ref_var: per reference stamp the known variance [m^2] of a position-only
    reference along each axis (None: sigma_ref is fitted, unless ``free_reference`` is False: then taken as 0).
    Returns a dict of the fit and its figures; a UserError where the drive cannot give a class."""
    ot, oxy, oyaw = (np.asarray(v, float) for v in odo[:3])
    rt, rxy = np.asarray(ref[0], float), np.asarray(ref[1], float)
    headings = ref[2] is not None
    oyaw = np.unwrap(oyaw)
    inside = (rt >= ot[0]) & (rt <= ot[-1])
    if inside.sum() < 2:
        raise UserError('the odometry (%.3f .. %.3f s) and the reference (%.3f .. %.3f s) do not overlap in time: '
                        '%d reference stamp(s) inside the odometry\'s span, at least 2 needed'
                        % (ot[0], ot[-1], rt[0], rt[-1], int(inside.sum())))
    rt, rxy = rt[inside], rxy[inside]
    ryaw = np.unwrap(np.asarray(ref[2], float)[inside]) if headings else None
    rvar = np.asarray(ref_var, float)[inside] if ref_var is not None else None
    window = window or (WINDOW_POSES if headings else WINDOW_POSITIONS)
    # The odometry at the reference stamps, and its travel (path length along its samples) there.
    pxy, pyaw = ev.interpolate(ot, oxy, oyaw, rt)
    otravel = np.r_[0.0, np.cumsum(np.hypot(*np.diff(oxy, axis=0).T))]
    travel = np.interp(rt, ot, otravel)
    ends = cut_windows(travel, window, alternate=not headings)
    windows, gaps, gap_travel = [], 0, 0.0
    for k, (a, b) in enumerate(zip(ends[:-1], ends[1:])):
        length = window * (2.0 if not headings and k % 2 else 1.0)
        if travel[b] - travel[a] > (1.0 + MAX_WINDOW_OVERSHOOT) * length:
            gaps += 1  # the reference has no stamp near the window's end: it spans a gap of the reference
            gap_travel += travel[b] - travel[a]
            windows.append(None)
            continue
        lo, hi = np.searchsorted(ot, rt[a], side='right'), np.searchsorted(ot, rt[b], side='left')
        poses = np.vstack([[pxy[a, 0], pxy[a, 1], pyaw[a]], np.column_stack([oxy[lo:hi], oyaw[lo:hi]]),
                           [pxy[b, 0], pxy[b, 1], pyaw[b]]])
        if motion_noise_time:
            w = window_blocks(poses, np.r_[rt[a], ot[lo:hi], rt[b]], motion_noise_time)
        else:
            w = window_steps(poses, motion_step, motion_step_angle)
        w.update(start=a, end=b, window=length, seconds=rt[b] - rt[a])
        windows.append(w)
    # Consecutive windows (for the course changes), None where one was left out.
    sequence = windows
    windows = [w for w in windows if w is not None]
    ref_travel = float(sum(np.hypot(*(rxy[w['end']] - rxy[w['start']])) for w in windows))
    odo_travel = float(sum(w['travel'] for w in windows))
    turn = float(sum(w['turn'] for w in windows))
    what = ('%d window(s) of %g m of odometry travel (%.1f m of odometry, %.1f m of reference chords, %.2f rad '
            'turned)' % (len(windows), window, odo_travel, ref_travel, turn))
    if gaps:
        what += ', %d more across gaps of the reference (%.0f m) left out' % (gaps, gap_travel)
    if len(windows) < MIN_WINDOWS:
        raise UserError('too little motion: %s where the odometry and the reference overlap; at least %d windows '
                        'needed (drive more, or a shorter --window)' % (what, MIN_WINDOWS))
    if ref_travel < MIN_TRAVEL_WINDOWS * window:
        raise UserError('too little motion: the reference moved %.1f m over %s, at least %d windows\' worth (%g m) '
                        'needed (is it the right topic?)' % (ref_travel, what, MIN_TRAVEL_WINDOWS,
                                                             MIN_TRAVEL_WINDOWS * window))
    if turn < MIN_TURN:
        raise UserError('too little turning: %s; alpha1 and alpha4 (the noise from turning) need at least %.2f rad '
                        '(one full turn) in total: drive curves, or turn on the spot' % (what, MIN_TURN))
    obs = _observations(sequence, rxy, ryaw, pyaw, rvar)
    free = not headings and rvar is None and free_reference
    params, nll, se = fit(obs, free_reference=free)
    v = variances(obs, params)
    inside95 = np.abs(obs['e']) <= Z95 * np.sqrt(v)
    out = {'windows': len(windows), 'gaps': gaps, 'gap_travel': gap_travel, 'window': window, 'alternate': not headings, 'headings': headings,
           'odometry_travel': odo_travel, 'reference_travel': ref_travel, 'turn': turn,
           'seconds': float(sum(w['seconds'] for w in windows)), 'steps': int(sum(len(w['steps']) for w in windows)),
           'alphas': [float(a) for a in params[:4]], 'alpha_se': [float(s) for s in se[:4]],
           'sigma_ref': float(params[4]) if free else None, 'sigma_ref_se': float(se[4]) if free else None,
           'sigma_ref_known': (float(np.sqrt(np.median(rvar))) if rvar is not None else None),
           'nll': nll, 'observations': int(len(obs['e'])), 'coverage': {}, 'bias': {},
           'motion_step': motion_step, 'motion_step_angle': motion_step_angle,
           'motion_noise_time': motion_noise_time}
    for k in ('heading', 'course', 'distance'):
        sel = obs['kind'] == k
        if np.any(sel):
            out['coverage'][k] = (float(np.mean(inside95[sel])), int(sel.sum()))
            out['bias'][k + '_rms'] = float(np.sqrt(np.mean(obs['e'][sel] ** 2)))
            out['bias'][k + '_rms_predicted'] = float(np.sqrt(np.mean(v[sel])))
    out['coverage']['all'] = (float(np.mean(inside95)), int(len(inside95)))
    dist = obs['kind'] == 'distance'
    if np.any(dist):
        lengths = np.array([float(np.hypot(*w['chord'])) for w in windows
                            if float(np.hypot(*w['chord'])) >= MIN_CHORD_SHARE * w['window']])
        out['bias']['scale'] = float(np.sum(obs['e'][dist]) / np.sum(lengths))
    if headings:
        out['bias']['heading_per_m'] = float(np.sum(obs['e'][obs['kind'] == 'heading']) / odo_travel)
    elif np.any(obs['kind'] == 'course'):
        # A heading drift turns each chord against the one before by the drift times the travel between them.
        between = sum(0.5 * (sequence[k - 1]['travel'] + sequence[k]['travel']) for k in range(1, len(sequence))
                      if sequence[k - 1] is not None and sequence[k] is not None)
        out['bias']['heading_per_m'] = float(np.sum(obs['e'][obs['kind'] == 'course']) / between)
    return out


# --- Bag reading --------------------------------------------------------------------------------------------


def _bag_types(bag_path):
    import rosbag
    _input_file(bag_path)
    try:
        with rosbag.Bag(bag_path) as bag:
            return {topic: info.msg_type for topic, info in bag.get_type_and_topic_info().topics.items()}, \
                {topic: info.message_count for topic, info in bag.get_type_and_topic_info().topics.items()}
    except (rosbag.ROSBagException, ValueError, EOFError) as e:
        raise UserError('%s: not a readable bag (%s)' % (bag_path, ' '.join(str(e).split()) or type(e).__name__))


def _input_file(path):
    """``path`` if it is a readable file, else an OSError naming the problem (see convert_common.input_file)."""
    from rbpf_slam.convert_common import input_file
    return input_file(path)


def _listing(types):
    return ', '.join('%s (%s)' % (t, ty) for t, ty in sorted(types.items())) or 'no topics'


def read_odometry(bag_path, topic, count=None, progress=False):
    """(t, xy, yaw) of the nav_msgs/Odometry on ``topic``, sorted by stamp (an unstamped message: its bag time),
    a repeated stamp kept once (its last message)."""
    import genpy
    import rosbag
    rows = []
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=count, unit=' msg', desc='reading ' + topic, disable=None, leave=False, mininterval=0.5)
    try:
        with rosbag.Bag(bag_path) as bag:
            for _, msg, bag_time in bag.read_messages(topics=[topic]):
                p, q = msg.pose.pose.position, msg.pose.pose.orientation
                t = msg.header.stamp.to_sec()
                rows.append((t if t > 0 else bag_time.to_sec(), p.x, p.y,
                             math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))))
                if bar is not None:
                    bar.update(1)
    except (rosbag.ROSBagException, genpy.DeserializationError, ValueError, EOFError) as e:
        raise UserError('%s: cannot read %s (%s)' % (bag_path, topic, ' '.join(str(e).split())))
    finally:
        if bar is not None:
            bar.close()
    data = np.array(rows, float).reshape(-1, 4)
    data = data[np.all(np.isfinite(data), axis=1)]
    data = data[np.argsort(data[:, 0], kind='stable')]
    if len(data) > 1:
        keep = np.r_[data[1:, 0] > data[:-1, 0], True]
        data = data[keep]
    if len(data) < 2:
        raise UserError('%s: %d valid message(s) on %s (%s), at least 2 needed' % (bag_path, len(data), topic,
                                                                                 ODOMETRY_TYPE))
    return data[:, 0], data[:, 1:3], data[:, 3]


def pick_reference(bag_path, types, requested, odom_topic):
    """The reference topic: ``requested``, or the first of evaluate's DEFAULT_REFERENCE_TOPICS in the bag (else
    its only NavSatFix topic), as evaluate_bag_run picks it; a UserError naming what was looked for and what
    the bag has."""
    if requested is not None:
        topic = requested if requested in types else ev._slash(requested)
        if topic not in types:
            raise UserError('%s: no reference topic %s (--reference); the bag has %s'
                            % (bag_path, requested, _listing(types)))
        if types[topic] not in ev.REFERENCE_TYPES:
            raise UserError('%s: the reference %s is %s, not one of %s' % (bag_path, topic, types[topic],
                                                                           ', '.join(ev.REFERENCE_TYPES)))
    else:
        topic = next((t for t in ev.DEFAULT_REFERENCE_TOPICS if types.get(t) in ev.REFERENCE_TYPES), None)
        if topic is None:
            fixes = sorted(t for t, ty in types.items() if ty == 'sensor_msgs/NavSatFix')
            topic = fixes[0] if len(fixes) == 1 else None
        if topic is None:
            raise UserError('%s: no reference: looked for %s (of %s) and for one sensor_msgs/NavSatFix topic; the '
                            'bag has %s (--reference TOPIC to name one)'
                            % (bag_path, ', '.join(ev.DEFAULT_REFERENCE_TOPICS), ', '.join(ev.REFERENCE_TYPES),
                               _listing(types)))
    if topic == odom_topic:
        raise UserError('%s: the reference %s is the odometry itself (--odom)' % (bag_path, topic))
    return topic


def navsat_variances(bag_path, topic, t):
    """Per reference stamp ``t`` (the valid fixes, sorted as read_bag_reference sorts them) the variance [m^2]
    of a NavSatFix's horizontal position (the mean of its east and north variances), or None unless every
    valid fix states one (position_covariance_type > 0, finite, > 0)."""
    import rosbag
    rows = []
    with rosbag.Bag(bag_path) as bag:
        for _, msg, bag_time in bag.read_messages(topics=[topic]):
            ok = msg.status.status >= 0 and abs(msg.latitude) <= 90.0 and abs(msg.longitude) <= 180.0
            s = msg.header.stamp.to_sec()
            s = s if s > 0 else bag_time.to_sec()
            if not (ok and math.isfinite(msg.latitude) and math.isfinite(msg.longitude) and math.isfinite(s)):
                continue
            c = msg.position_covariance
            var = 0.5 * (c[0] + c[4]) if msg.position_covariance_type > 0 else float('nan')
            rows.append((s, var))
    data = np.array(rows, float).reshape(-1, 2)
    data = data[np.argsort(data[:, 0], kind='stable')]
    if len(data) != len(t) or not np.all(np.isfinite(data[:, 1]) & (data[:, 1] > 0)):
        return None
    return data[:, 1]


def constant_heading(yaw, xy):
    """True where a reference's headings say nothing: the same heading throughout while the positions move."""
    moved = float(np.sum(np.hypot(*np.diff(xy, axis=0).T))) if len(xy) > 1 else 0.0
    return moved > 1.0 and float(np.ptp(np.unwrap(yaw))) < 1e-6


# --- Output -------------------------------------------------------------------------------------------------


def significant(v, digits=3):
    """A number rounded to ``digits`` significant digits, written with a decimal point (a YAML float)."""
    if v == 0 or not math.isfinite(v):
        return '0.0' if v == 0 else repr(v)
    d = digits - 1 - int(math.floor(math.log10(abs(v))))
    text = ('%.*f' % (max(d, 1), round(v, d))).rstrip('0')
    return text + '0' if text.endswith('.') else text


def _pm(v, se):
    return significant(v) + (' +- %s' % significant(se, 2) if se is not None and math.isfinite(se) else '')


def fit_lines(r):
    """The fit's figures as lines of text."""
    a, se = r['alphas'], r['alpha_se']
    lines = []
    if r['headings']:
        lines.append('windows: %d of %g m of odometry travel, ends at reference stamps; per window the heading '
                     'change error and the distance (chord length) error' % (r['windows'], r['window']))
    else:
        lines.append('windows: %d of %g m and %g m of odometry travel by turns (two lengths, so that the '
                     'reference\'s own noise, the same in every window, is told from the odometry\'s, which grows '
                     'with the length), ends at reference fixes; per window the distance (chord length) error, per '
                     'two consecutive windows the error of the course change between their chords'
                     % (r['windows'], r['window'], 2 * r['window']))
    if r.get('motion_noise_time'):
        lines.append('driven: %.1f m (odometry; %.1f m of reference chords), %.1f rad turned (sum of |turn| of its '
                     'arcs, in %d blocks of up to %g s), %.0f s'
                     % (r['odometry_travel'], r['reference_travel'], r['turn'], r['steps'], r['motion_noise_time'],
                        r['seconds']))
    else:
        lines.append('driven: %.1f m (odometry; %.1f m of reference chords), %.1f rad turned (sum of |rot1| + '
                     '|rot2| over %d steps), %.0f s' % (r['odometry_travel'], r['reference_travel'], r['turn'],
                                                       r['steps'], r['seconds']))
    if r['gaps']:
        lines.append('left out: %d windows across gaps of the reference (%.0f m of odometry travel without a '
                     'reference stamp near the window\'s end)' % (r['gaps'], r['gap_travel']))
    b = r['bias']
    parts = []
    if 'scale' in b:
        parts.append('distance scale error %+.2f %% (reference minus odometry)' % (100 * b['scale']))
    if 'heading_per_m' in b:
        parts.append('heading drift %+.4f rad/m (%+.2f deg per 10 m; reference minus odometry)'
                     % (b['heading_per_m'], math.degrees(10 * b['heading_per_m'])))
    lines.append('mean errors (biases): %s; the class takes them as noise' % '; '.join(parts))
    rms = []
    for k, unit in (('heading', 'rad'), ('course', 'rad'), ('distance', 'm')):
        if k + '_rms' in b:
            rms.append('%s %.4f %s (model %.4f)' % (k, b[k + '_rms'], unit, b[k + '_rms_predicted']))
    lines.append('RMS errors: ' + ', '.join(rms))
    units = (('rad/s per rad/s', 'rad/s per m/s', 'm/s per m/s', 'm/s per rad/s') if r.get('motion_noise_time')
             else ('rad/rad', 'rad/m', 'm/m', 'm/rad'))
    lines.append('fitted (maximum likelihood, the errors taken as independent Gaussians; +- approximate standard '
                 'errors): alpha1 %s %s, alpha2 %s %s, alpha3 %s %s, alpha4 %s %s'
                 % tuple(x for k in range(4) for x in (_pm(a[k], se[k]), units[k])))
    loose = ['%s (+- %.0f %%)' % ('alpha%d' % (k + 1), 100 * se[k] / a[k]) for k in range(4)
             if a[k] > 0 and math.isfinite(se[k]) and se[k] > 0.5 * a[k]]
    zero = ['alpha%d' % (k + 1) for k in range(4) if a[k] == 0 or not math.isfinite(se[k])]
    if loose or zero:
        lines.append('poorly determined by these data: %s' % ', '.join(
            loose + (['%s (at or near 0: the data do not ask for it, or cannot tell it from the others)'
                      % ', '.join(zero)] if zero else [])))
    if r['sigma_ref'] is not None:
        lines.append('reference noise (fitted, per axis, independent per fix): sigma_ref %s m'
                     % _pm(r['sigma_ref'], r['sigma_ref_se']))
    elif r['sigma_ref_known'] is not None:
        lines.append('reference noise from the NavSatFix covariance: sigma_ref %.3f m (median, per axis)'
                     % r['sigma_ref_known'])
    elif r['headings']:
        lines.append('reference noise: none assumed (ground truth with headings)')
    cov = r['coverage']
    lines.append('check: inside the fitted model\'s 95 %% interval: %s (about 95 %% expected)'
                 % ', '.join('%s %.1f %% of %d' % (k, 100 * cov[k][0], cov[k][1])
                             for k in ('heading', 'course', 'distance', 'all') if k in cov))
    return lines


def _comment(text, width=116):
    import textwrap
    return ['# ' + line for line in textwrap.wrap(text, width - 2, subsequent_indent='  ', break_on_hyphens=False)]


def yaml_text(r, command, name, odom_topic, reference_line, bag):
    """The class as YAML in the style of config/odometry/*.yaml: comments, then motion and the steps."""
    velocity = bool(r.get('motion_noise_time'))
    model = ('the velocity model: the odometry is commanded velocities integrated, their errors held over blocks of '
             'motion_noise_time seconds' if velocity else
             'standard deviations per step of at most motion_step and motion_step_angle, adding up as a random walk')
    out = _comment('Odometry accuracy class: %s. Fitted by calibrate_odometry to the odometry %s of %s against its '
                   'reference. Load after the filter\'s configuration (see config/odometry/forest_atv.yaml for how, '
                   'and for the model: %s).' % (name, odom_topic, bag, model))
    out.append('# Made by:')
    out.append('#   ' + command)
    out += _comment(reference_line)
    if velocity:
        out += _comment('The heading error variance of a window is the sum over its blocks of (alpha1 A + alpha2 '
                        'D)^2, the distance error variance that of (alpha3 D + alpha4 A)^2 along the chord plus the '
                        'lateral shift of the rest of the window by each block\'s turn error (to first order).')
    else:
        out += _comment('The heading error variance of a window is the sum over its steps of sigma_rot1^2 + '
                        'sigma_rot2^2, the distance error variance that of sigma_trans^2 along the chord plus the '
                        'lateral shift of the rest of the window by each step\'s rot noise (to first order).')
    for line in fit_lines(r):
        out += _comment('- ' + line)
    out.append('motion: {alpha1: %s, alpha2: %s, alpha3: %s, alpha4: %s}' % tuple(significant(a) for a in r['alphas']))
    if velocity:
        out.append('motion_model: velocity')
        out.append('motion_noise_time: %s' % _plain(r['motion_noise_time']))
    else:
        out.append('motion_step: %s' % _plain(r['motion_step']))
        out.append('motion_step_angle: %s' % _plain(r['motion_step_angle']))
    return '\n'.join(out) + '\n'


def _plain(v):
    s = '%.6g' % v
    return s if ('.' in s or 'e' in s) else s + '.0'


# --- Command ------------------------------------------------------------------------------------------------


def _positive(text):
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError('not a number: %r' % text)
    if not (v > 0 and math.isfinite(v)):
        raise argparse.ArgumentTypeError('must be > 0: %r' % text)
    return v


def main(argv=None, doc=None):
    """The command: exit code 0, or 1 with one line on stderr (see rbpf_slam.atomic.run_tool); -o is written
    atomically, and not at all on a failure."""
    return atomic.run_tool(PROG, _main, argv, doc, errors=(ValueError, KeyError))


def _main(argv, doc):
    p = argparse.ArgumentParser(prog=PROG, description=doc or USAGE,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('bag', help='the bag with the odometry and the reference')
    p.add_argument('--odom', default='/odom', metavar='TOPIC', help='odometry, nav_msgs/Odometry (default /odom)')
    p.add_argument('--reference', metavar='TOPIC',
                   help='reference path (Odometry, PoseStamped, PoseWithCovarianceStamped, PointStamped or '
                        'NavSatFix); default: the first of %s in the bag, else its only NavSatFix topic'
                        % ', '.join(ev.DEFAULT_REFERENCE_TOPICS))
    p.add_argument('--motion-step', type=_positive, default=0.2, metavar='M',
                   help='the filter\'s motion_step [m] (default 0.2)')
    p.add_argument('--motion-step-angle', type=_positive, default=0.2, metavar='RAD',
                   help='the filter\'s motion_step_angle [rad] (default 0.2)')
    p.add_argument('--motion-model', choices=('odometry', 'velocity'), default='odometry',
                   help='the filter\'s motion_model: odometry (measured increments, default) or velocity (the '
                        'odometry is commanded velocities integrated)')
    p.add_argument('--motion-noise-time', type=_positive, default=1.0, metavar='S',
                   help='the velocity model\'s motion_noise_time [s] (default 1.0)')
    p.add_argument('--window', type=_positive, metavar='M',
                   help='window [m of odometry travel] (default %g with reference headings, %g for a reference of '
                        'positions only)' % (WINDOW_POSES, WINDOW_POSITIONS))
    p.add_argument('-o', '--output', metavar='FILE.yaml', help='also write the class here (atomically)')
    p.add_argument('--name', metavar='TEXT', help='what the class is for (the first comment line)')
    p.add_argument('-q', '--quiet', action='store_true', help='no progress bar')
    args = p.parse_args(argv)
    if args.output:
        atomic.check_output(args.output)
    command = ' '.join([PROG] + [shlex.quote(a) for a in (sys.argv[1:] if argv is None else argv)])
    types, counts = _bag_types(args.bag)
    odom = args.odom if args.odom in types else ev._slash(args.odom)
    if odom not in types:
        raise UserError('%s: no odometry topic %s (--odom); the bag has %s' % (args.bag, args.odom, _listing(types)))
    if types[odom] != ODOMETRY_TYPE:
        raise UserError('%s: the odometry %s is %s, not %s' % (args.bag, odom, types[odom], ODOMETRY_TYPE))
    ref_topic = pick_reference(args.bag, types, args.reference, odom)
    ref = ev.read_bag_reference(args.bag, ref_topic, 'none')
    odo = read_odometry(args.bag, odom, counts.get(odom), progress=not args.quiet)
    ref_line = next((n for n in ref['notes'] if n.startswith('reference:')), 'reference: %s' % ref_topic)
    if args.reference is None:
        ref_line = ref_line.replace(' (%s)' % ref['type'], ' (%s, found in the bag, --reference to choose)'
                                    % ref['type'], 1)
    yaw = ref['yaw']
    if yaw is None:
        ref_line += '; positions only (no orientation in the messages)'
    elif constant_heading(yaw, ref['xy']):
        yaw = None
        ref_line += '; positions only (the same orientation throughout: it carries no heading)'
    else:
        ref_line += '; with headings'
    ref_var = None
    if yaw is None and ref['type'] == 'sensor_msgs/NavSatFix':
        ref_var = navsat_variances(args.bag, ref_topic, ref['t'])
        ref_line += ('; its noise from the fixes\' covariance' if ref_var is not None
                     else '; no covariance in every fix: its noise is fitted')
    result = calibrate(odo, (ref['t'], ref['xy'], yaw), args.motion_step, args.motion_step_angle, args.window,
                       ref_var=ref_var,
                       motion_noise_time=args.motion_noise_time if args.motion_model == 'velocity' else None)
    name = args.name or 'fitted to %s' % os.path.basename(args.bag)
    text = yaml_text(result, command, name, odom, ref_line, args.bag)
    if args.output:
        atomic.write_text(args.output, text)
    sys.stdout.write(text)
    return 0
