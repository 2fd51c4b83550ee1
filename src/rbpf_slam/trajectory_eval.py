"""Scores trajectory files against a bag's reference path (nav_msgs/Odometry), with the metrics of the
package's one evaluator (rbpf_slam.evaluate, as evaluate_bag_run).

  rosrun rbpf_slam trajectory_eval --bag intel.bag [--truth /ground_truth/odom] [--travel 1.0]
      [--pair stamp|index] [--tolerance 0.001] [--write-reference FILE.tum]
      [--write-odometry FILE.tum [--odom /odom]] RUN/estimate.tum RUN/odometry.tum other.txt ...

Files: one pose a line, either TUM (8 columns: t x y z qx qy qz qw, as the package writes estimate.tum and
odometry.tum) or "t x y theta" (4 columns, theta in rad: e.g. another SLAM system's pose at each laser scan
of a log, in file order), told apart per file; blank lines and lines starting with # are skipped. Anything
else is an error "FILE:LINE: expected ...".

Pairing of a file's poses with the reference's:
  --pair stamp (default)  the reference pose nearest in stamp (the later one on a tie), kept within
                          --tolerance seconds; order-preserving: where several poses share a stamp, the k-th
                          of them is paired with the k-th reference pose of that stamp (file order; a k-th
                          pose without a k-th reference pose stays unpaired), and no pose is paired with a
                          reference pose before the one paired with the pose before it (the reference's
                          stamps must not go backwards). Where several poses get one reference pose
                          (stamps coarser than the poses), a warning on stderr says how many.
  --pair index            the k-th pose of the file with the k-th reference pose (for files whose stamps
                          are not the bag's, e.g. a log's own stamps where the converter re-timed them); the
                          file and the reference must have as many poses (an error naming both otherwise).

Metrics over the paired poses: RPE over pose pairs --travel metres of reference travel apart (mean and RMS of
the translation [m] and rotation [deg] errors of the relative motion); the ATE RMS [m] after a least-squares
rigid SE(2) fit, and the ATE RMS [m] aligned at the first pose (the file's first paired pose put on the
reference's first paired pose, position and heading; no fit).

Prints one line per file: name, poses paired, RPE mean translation [m] and rotation [deg], their RMS, ATE
after the fit [m], ATE aligned at the first pose [m] ("-" for the rotation and the first-pose ATE where the
reference has positions only).

--write-reference writes the reference as a TUM file; --write-odometry the bag's odometry (--odom,
nav_msgs/Odometry) at the reference's stamps (interpolated, one pose per reference pose), as a TUM file that
either pairing scores like a run. Their stamps are written to the nanosecond.
"""
import argparse
import sys

from rbpf_slam import atomic, evaluate as ev


def _num(v, fmt):
    """v in fmt ('%W.Pf'), or '-' as wide for None."""
    return '%*s' % (int(fmt[1:fmt.index('.')]), '-') if v is None else fmt % v


def main(argv=None):
    """The command: exit code 0; 1 with one line on stderr for a missing or malformed input; 2 for a usage
    error."""
    return atomic.run_tool('trajectory_eval', _main, argv, errors=(ValueError,))


def _main(argv):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('--bag', required=True, help='the bag with the reference')
    p.add_argument('--truth', default='/ground_truth/odom', help='nav_msgs/Odometry reference topic')
    p.add_argument('--travel', type=float, default=1.0, help='RPE pair distance along the reference [m]')
    p.add_argument('--pair', choices=ev.PAIRINGS, default='stamp',
                   help='pair poses by stamp (default) or by index (the k-th with the k-th)')
    p.add_argument('--tolerance', type=float, default=1e-3, help='stamp pairing tolerance [s] (--pair stamp)')
    p.add_argument('--write-reference', metavar='FILE.tum', help='write the reference as a TUM file')
    p.add_argument('--write-odometry', metavar='FILE.tum',
                   help="write the bag's odometry at the reference's stamps as a TUM file")
    p.add_argument('--odom', default='/odom', help='nav_msgs/Odometry odometry topic (--write-odometry)')
    p.add_argument('files', nargs='*', metavar='FILE', help='trajectories to score (TUM or t x y theta)')
    args = p.parse_args(argv)
    if not args.travel > 0 or not args.tolerance >= 0:
        p.error('--travel must be positive and --tolerance not negative')
    ref_t, ref_xy, ref_yaw, _ = ev.read_bag_truth(args.bag, args.truth)
    if args.write_odometry:
        odo_t, odo_xy, odo_yaw, _ = ev.read_bag_truth(args.bag, args.odom, what='the odometry')
        xy, yaw = ev.interpolate(odo_t, odo_xy, odo_yaw if odo_yaw is not None else [0.0] * len(odo_t), ref_t)
        atomic.write_text(args.write_odometry, ev.tum_text(ref_t, xy, yaw))
    if args.write_reference:
        atomic.write_text(args.write_reference,
                          ev.tum_text(ref_t, ref_xy, ref_yaw if ref_yaw is not None else [0.0] * len(ref_t)))
    runs = [(path, ev.read_trajectory(path)) for path in args.files]  # every file read before the table
    if args.pair == 'index':
        for path, run in runs:
            if len(run[0]) != len(ref_t):
                raise ValueError('%s has %d poses, the reference (%s in %s) %d: --pair index needs as many'
                                 % (path, len(run[0]), args.truth, args.bag, len(ref_t)))
    print('%-40s %7s %9s %9s %9s %10s %9s %10s' % ('trajectory', 'poses', 'RPE m', 'RPE deg', 'RPErms m',
                                                  'RPErms deg', 'ATEfit m', 'ATEfirst m'))
    for path, run in runs:
        try:
            e = ev.trajectory_errors(run, (ref_t, ref_xy, ref_yaw), args.travel, args.tolerance, args.pair)
        except ValueError as err:
            raise ValueError('%s: %s' % (path, err))
        if e['shared_partners']:
            sys.stderr.write('trajectory_eval: warning: %s: %d of %d paired poses share their reference pose with '
                             'another pose (stamps coarser than the poses; --pair index pairs by order)\n'
                             % (path, e['shared_partners'], e['poses']))
        print('%-40s %7d %9.4f %s %9.4f %s %9.4f %s' % (
            path, e['poses'], e['rpe_translation_mean'], _num(e['rpe_rotation_mean_deg'], '%9.3f'),
            e['rpe_translation_rms'], _num(e['rpe_rotation_rms_deg'], '%10.3f'), e['ate'],
            _num(e['ate_first_pose'], '%10.4f')))
    return 0

