"""Scores an offline run (slam_bag --out DIR) against the reference topics of the bag it ran on.

  rosrun rbpf_slam evaluate_bag_run --bag FILE --run DIR [--reference TOPIC|none] [--truth-landmarks TOPIC|none]
      [--point-offset X Y] [--no-fit] [--gate M] [--rpe-distance M] [--include-provisional] [--no-plot] [--quiet]

The reference path is one of nav_msgs/Odometry, geometry_msgs/PoseStamped, PoseWithCovarianceStamped,
geometry_msgs/PointStamped (a GPS in a local metric frame: x, y [m]) or sensor_msgs/NavSatFix (latitude /
longitude, converted to a local east-north tangent plane on the WGS84 ellipsoid about the first valid fix;
fixes with status < 0 (no fix) or values that are not finite are skipped and counted). Without --reference the
first of /ground_truth/odom, /gps/fix, /gps, /fix in the bag is used (else its only NavSatFix topic), and the
output says which. The estimate is interpolated at the reference stamps inside its time span; the output says
how many of the reference's poses or fixes that is.

The true landmarks are the first rbpf_slam/TrunkArray on --truth-landmarks (default: /ground_truth/landmarks of
the data set converters, else the simulator's /ground_truth/trees); the map.csv is matched to them one-to-one
(optimal assignment) inside --gate (default 0.5 m; 1.0 m on the park drive) and counted as matched (recall of
all true landmarks), duplicates and spurious. A bag without one of the two is scored on the other, and a line
says what is missing.

By default the figures are given twice, side by side: after a least-squares rigid 2D fit of the compared
points onto the reference (the ATE; the map moved by the estimate's fit), and without a fit (the run's frame
taken as the reference's, as where the start pose is known); --no-fit gives only the latter. Where the
reference has headings, the ATE is also given aligned at the first pose ("at the first pose": the run moved so
that its pose at the first compared reference stamp lies on the reference's, position and heading; no fit).
Without a reference path the map is fitted onto the true landmarks by a rigid fit over its one-to-one matches, the
transform searched over pairs of landmarks (and the ids, where the map's are the truth's) wherever the map's frame
lies; a fit over fewer than 3 matches is refused and the map scored in its own frame (said in the output). The
compared point is base_link moved by --point-offset (the LEGO logs' reference is the scanner, 0.03 m ahead:
--point-offset 0.03 0; a GPS antenna's offset likewise).

Prints a table (estimate beside the run's raw odometry) and writes DIR/evaluation.json (both figures; "no_fit"
holds the figures without a fit) and DIR/evaluation.png (paths with the reference, the map with the true
landmarks, the error over time). A bad input is one line on stderr and exit code 1, nothing written.
"""
import argparse
import json
import os

from rbpf_slam import atomic, evaluate as ev


def _mm(v):
    return '%8.1f' % (1000.0 * v) if v is not None else '       -'


PATH_ROWS = (('path_rms', 'ATE / path RMS [mm]'), ('final_error', 'final error [mm]'),
             ('max_error', 'max error [mm]'), ('rpe_translation', 'RPE trans. [mm]'))


def _map_lines(m, label):
    lines = ['%s: %d features for %d true landmarks: %d matched (recall %.0f %%), %d duplicates, %d spurious'
             % (label, m['features'], m['trees'], m['matched'], 100 * m['recall'], m['duplicates'], m['spurious'])]
    if m['mean_error'] is not None:
        lines.append('     landmark error mean %s mm, RMS %s mm, max %s mm; radius RMS %s mm'
                     % (_mm(m['mean_error']).strip(), _mm(m['rms_error']).strip(), _mm(m['max_error']).strip(),
                        _mm(m['radius_rms']).strip()))
    return lines


def table(summary):
    """The printed report: the reference lines, the path figures (fitted and without a fit side by side where
    both were computed), the map."""
    lines = list(summary.get('notes', []))
    est, odo = summary.get('estimate'), summary.get('odometry', {})
    no_fit = summary.get('no_fit')
    fitted = summary['fit'] != 'none'
    if est is not None:
        lines.append('compared: %d of %d reference %s inside the estimate\'s time span'
                     % (summary['reference_poses'], summary['reference_total'],
                        'fixes' if summary.get('reference_positions_only') else 'poses'))
        if no_fit is not None:
            cols = [('estimate', est), ('no fit', no_fit.get('estimate', {})),
                    ('odometry', odo), ('no fit', no_fit.get('odometry', {}))]
            lines.append(('%-22s %10s %10s %10s' % ('', 'estimate', '', 'odometry')).rstrip())
            lines.append('%-22s %10s %10s %10s %10s' % ('', 'fitted', 'no fit', 'fitted', 'no fit'))
        else:
            cols = [('estimate', est), ('odometry', odo)]
            lines.append('%-22s %10s %10s' % ('(%s)' % ('fitted' if fitted else 'no fit'), 'estimate', 'odometry'))

        def row(label, fmt, key, fitted_only=False):
            cells = ['' if fitted_only and k == 'no fit' else fmt(c[key]) if c.get(key) is not None else '-'
                     for k, c in cols]  # a fit-independent figure is given once, in the fitted column
            return ('%-22s' % label + ''.join(' %10s' % v for v in cells)).rstrip()
        for key, label in PATH_ROWS:
            lines.append(('%-22s' % label + ''.join(' %10s' % _mm(c.get(key)) for _, c in cols)).rstrip())
            if key == 'path_rms' and est.get('path_rms_first_pose') is not None:
                lines.append(row('  at the first pose', lambda v: _mm(v).strip(), 'path_rms_first_pose', True))
        if est.get('path_rms_similarity') is not None:
            lines.append(row('path RMS, scaled [mm]', lambda v: _mm(v).strip(), 'path_rms_similarity', True))
            lines.append(row('  with scale', lambda v: '%.4f' % v, 'similarity_scale', True))
        if est.get('rpe_rotation_deg') is not None:
            lines.append(row('RPE rot. [deg]', lambda v: '%.2f' % v, 'rpe_rotation_deg'))
        if fitted:
            tr = est['transform']
            lines.append('estimate fit: rotation %.2f deg, translation (%.3f, %.3f) m'
                         % (tr['rotation_deg'], tr['translation'][0], tr['translation'][1]))
    elif 'map_fit' in summary:
        f = summary['map_fit']
        if not f.get('refused'):
            lines.append('no reference path: the map is fitted onto the true landmarks by a rigid fit over its %d '
                         'one-to-one matches (rotation %.2f deg, translation (%.3f, %.3f) m; found by a search over '
                         'pairs of landmarks)'
                         % (f['matches'], f['rotation_deg'], f['translation'][0], f['translation'][1]))
        else:
            lines.append('no reference path, and under no rigid transform do %d map features match a true landmark '
                         '(%d at most): no fit, which would be no score; the map is scored in its own frame'
                         % (ev.MIN_MAP_FIT_MATCHES, f['matches']))
    m = summary.get('map')
    if m:
        label = 'map' if no_fit is None or 'map' not in no_fit else 'map (fitted)'
        lines += _map_lines(m, label)
        if no_fit is not None and 'map' in no_fit:
            lines += _map_lines(no_fit['map'], 'map (no fit)')
    for key, what in (('coverage_95', 'the published estimate\'s'), ('coverage_95_cloud', 'the particle cloud\'s')):
        if key in summary:
            c = summary[key]
            lines.append('truth inside %s 95 %% region: %.1f %% of %d reference poses (fitted), %.1f %% (no fit)'
                         % (what, 100 * c['fitted'], c['compared'], 100 * c['no_fit']))
    if 'health_warned_updates' in summary:
        line = 'health warned in %d of %d updates' % tuple(summary['health_warned_updates'])
        causes = summary.get('health_warned_by_cause') or {}
        if causes:
            line += ' (%s)' % ', '.join('%s: %d' % (c, causes[c]) for c in sorted(causes))
        lines.append(line)
    if 'seconds_processing' in summary:
        lines.append('processing %.1f ms (%d sweeps)' % (1000 * summary['seconds_processing'], summary.get('sweeps', 0)))
    return '\n'.join(lines)


def plot(path, summary, transforms, ref, truth_map):
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig, (a, b) = plt.subplots(1, 2, figsize=(13, 5.5))
    if ref is not None:
        rt, rxy = ref
        a.plot(rxy[:, 0], rxy[:, 1], 'k-' if len(rxy) > 1 else 'k.', lw=2, label='reference')
    if 'odometry' in transforms:
        o = transforms['odometry'][2]
        a.plot(o[:, 0], o[:, 1], '-', color='tab:orange', label='raw odometry')
    e = transforms['estimate'][2]
    a.plot(e[:, 0], e[:, 1], '-', color='tab:blue', label='estimate')
    if truth_map is not None and len(truth_map):
        a.plot(truth_map[:, 0], truth_map[:, 1], 'o', ms=9, mfc='none', mec='g', label='true landmarks')
    if 'map' in transforms and len(transforms['map']):
        a.plot(transforms['map'][:, 0], transforms['map'][:, 1], 'x', color='r', label='estimated landmarks')
    a.set_aspect('equal')
    a.grid(True)
    a.legend(fontsize=8)
    how = {'rigid_2d': 'fitted onto the reference', 'map_rigid_2d': 'map fitted onto the true landmarks'}
    a.set_title('paths (%s) and map' % how.get(summary['fit'], 'no fit'))
    if ref is not None:
        b.plot(rt - rt[0], transforms['estimate'][3], label='estimate')
        if 'odometry' in transforms:
            b.plot(rt - rt[0], transforms['odometry'][3], label='raw odometry')
        b.set_xlabel('time [s]')
        b.set_ylabel('position error [m]')
        b.grid(True)
        b.legend()
    else:
        b.axis('off')
        b.text(0.5, 0.5, 'no reference path', ha='center', va='center')
    fig.tight_layout()
    atomic.save_figure(fig, path, dpi=90)
    plt.close(fig)


def main(argv=None):
    """The command: exit code 0, or 1 with one line on stderr for a missing or malformed input (see
    rbpf_slam.atomic.run_tool); the outputs are written atomically."""
    return atomic.run_tool('evaluate_bag_run', _main, argv, errors=(ValueError, KeyError))


def _main(argv):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('--bag', required=True, help='the bag the run read (its reference topics are read here)')
    p.add_argument('--run', required=True, help='output folder of slam_bag --out')
    p.add_argument('--reference', '--truth-odom', dest='reference', metavar='TOPIC',
                   help='reference path topic (Odometry, PoseStamped, PointStamped or NavSatFix); default: the '
                        'first of %s in the bag, else its only NavSatFix topic; "none": score the map alone'
                        % ', '.join(ev.DEFAULT_REFERENCE_TOPICS))
    p.add_argument('--truth-landmarks', metavar='TOPIC',
                   help='rbpf_slam/TrunkArray true landmarks; default: the first of %s in the bag; "none": no map '
                        'score' % ', '.join(ev.DEFAULT_LANDMARK_TOPICS))
    p.add_argument('--point-offset', nargs=2, type=float, default=(0.0, 0.0), metavar=('X', 'Y'),
                   help='compared point on base_link [m] (default 0 0)')
    p.add_argument('--no-fit', action='store_true',
                   help='only the figures without a fit (by default both, the fitted ones first)')
    p.add_argument('--gate', type=float, default=0.5, help='landmark match gate [m] (default 0.5)')
    p.add_argument('--rpe-distance', type=float, default=1.0, help='RPE pair distance [m] (default 1)')
    p.add_argument('--include-provisional', action='store_true', help='score provisional landmarks too')
    p.add_argument('--no-plot', action='store_true')
    p.add_argument('--quiet', action='store_true')
    args = p.parse_args(argv)
    if not args.gate > 0 or not args.rpe_distance > 0:
        p.error('--gate and --rpe-distance must be positive')
    est = ev.read_tum(os.path.join(args.run, 'estimate.tum'))
    odo_path = os.path.join(args.run, 'odometry.tum')
    odo = ev.read_tum(odo_path) if os.path.exists(odo_path) else None
    ref = ev.read_bag_reference(args.bag, args.reference, args.truth_landmarks)
    truth_map = ref['landmarks']
    map_path = os.path.join(args.run, 'map.csv')
    features, feature_ids = (ev.read_map_csv(map_path, args.include_provisional, with_ids=True)
                             if os.path.exists(map_path) else (None, None))
    notes = list(ref['notes'])
    if truth_map is not None and features is None:
        notes.append('map: no %s: the map is not scored' % map_path)
    if ref['t'] is None and (truth_map is None or features is None):
        raise ValueError('%s: nothing to score: no reference path, and %s'
                         % (args.bag, 'no true landmarks' if truth_map is None else 'no map.csv in ' + args.run))
    summary, transforms, compared = ev.evaluate(est, odo, ref['t'], ref['xy'], ref['yaw'], truth_map, features,
                                                tuple(args.point_offset), not args.no_fit, args.gate,
                                                args.rpe_distance, no_fit_too=True, feature_ids=feature_ids,
                                                truth_ids=ref['landmark_ids'])
    smoothed_path = os.path.join(args.run, 'estimate_smoothed.tum')
    if os.path.exists(smoothed_path):
        # Loop closure: the run smoothed at its end, scored the same way (its own fit).
        smoothed_map = os.path.join(args.run, 'map_smoothed.csv')
        s_features, s_ids = (ev.read_map_csv(smoothed_map, args.include_provisional, with_ids=True)
                             if os.path.exists(smoothed_map) else (None, None))
        s_summary, _, _ = ev.evaluate(ev.read_tum(smoothed_path), None, ref['t'], ref['xy'], ref['yaw'], truth_map,
                                      s_features, tuple(args.point_offset), not args.no_fit, args.gate,
                                      args.rpe_distance, no_fit_too=True, feature_ids=s_ids,
                                      truth_ids=ref['landmark_ids'])
        summary['smoothed'] = {k: s_summary.get(k) for k in ('estimate', 'map', 'no_fit')}
    summary['notes'] = notes
    summary['reference'] = {'topic': ref['topic'], 'type': ref['type'], 'frame': ref['frame'],
                            'messages': ref['messages'], 'skipped': ref['skipped'],
                            'origin_lat_lon': list(ref['origin']) if ref['origin'] else None,
                            'landmarks_topic': ref['landmarks_topic'], 'landmarks_frame': ref['landmarks_frame']}
    summary['reference_positions_only'] = ref['t'] is not None and ref['yaw'] is None
    summary['gate'] = args.gate
    timing_path = os.path.join(args.run, 'timing.json')
    if os.path.exists(timing_path):
        with open(timing_path) as f:
            timing = json.load(f)
        summary['seconds_processing'] = timing['seconds_extraction'] + timing['seconds_filter']
        summary['sweeps'] = timing['sweeps']
    updates = ev.read_updates_csv(os.path.join(args.run, 'updates.csv'))
    if updates is not None:
        warned = sum(1 for h in updates['health'] if h == 'warn')
        summary['health_warned_updates'] = [warned, len(updates['health'])]
        causes = {}
        for h, c in zip(updates['health'], updates['health_cause']):
            if h == 'warn':
                causes[c or 'unknown'] = causes.get(c or 'unknown', 0) + 1
        summary['health_warned_by_cause'] = causes
        if ref['t'] is not None and 'estimate' in transforms:
            rt, rxy = compared
            r, t = transforms['estimate'][:2]
            # The published estimate's region (what the robot is told), and the particle cloud's beside it.
            for region, key in (('estimate', 'coverage_95'), ('cloud', 'coverage_95_cloud')):
                share, n = ev.coverage_95(updates, rt, rxy, r, t, region)
                share_nf, _ = ev.coverage_95(updates, rt, rxy, region=region)
                if share is not None:
                    summary[key] = {'fitted': share, 'no_fit': share_nf, 'compared': n}
    text = table(summary)  # before any output, so that a failure leaves nothing behind
    atomic.write_json(os.path.join(args.run, 'evaluation.json'), summary, indent=2)
    if not args.no_plot:
        plot(os.path.join(args.run, 'evaluation.png'), summary, transforms, compared, truth_map)
    if not args.quiet:
        print(text)
    return 0

