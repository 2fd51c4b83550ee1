import errno
import json
import os
import signal
import time

import pytest

from rbpf_slam import atomic
from rbpf_slam.atomic import atomic_output


def test_complete_block_renames_to_target(tmp_path):
    target = tmp_path / 'out.bag'
    with atomic_output(str(target)) as tmp:
        assert tmp != str(target)
        with open(tmp, 'w') as f:
            f.write('data')
        assert not target.exists()
    assert target.read_text() == 'data'
    assert os.listdir(str(tmp_path)) == ['out.bag']


@pytest.mark.parametrize('error', [ValueError('bad line'), KeyboardInterrupt()])
def test_failed_block_leaves_nothing_and_keeps_an_old_file(tmp_path, error):
    target = tmp_path / 'out.bag'
    target.write_text('old')
    with pytest.raises(type(error)):
        with atomic_output(str(target)) as tmp:
            with open(tmp, 'w') as f:
                f.write('half')
            raise error
    assert target.read_text() == 'old'
    assert os.listdir(str(tmp_path)) == ['out.bag']


def test_missing_directory_is_a_clear_error(tmp_path):
    with pytest.raises(FileNotFoundError, match='does not exist'):
        with atomic_output(str(tmp_path / 'nope' / 'out.bag')):
            pass


def test_block_that_writes_nothing_is_an_error(tmp_path):
    with pytest.raises(RuntimeError, match='nothing was written'):
        with atomic_output(str(tmp_path / 'out.bag')):
            pass
    assert os.listdir(str(tmp_path)) == []


def test_os_error_about_the_temporary_file_names_the_target(tmp_path):
    target = str(tmp_path / 'out.bag')
    with pytest.raises(PermissionError) as e:
        with atomic_output(target) as tmp:
            open(tmp, 'w').close()
            raise PermissionError(errno.EACCES, 'Permission denied', tmp)
    assert e.value.filename == target and atomic.error_line(e.value) == '%s: permission denied' % target
    assert os.listdir(str(tmp_path)) == []


def test_output_that_cannot_be_a_file_is_refused_before_writing(tmp_path):
    (tmp_path / 'file').write_text('x')
    with pytest.raises(IsADirectoryError, match='is a directory'):
        atomic.check_output(str(tmp_path))
    with pytest.raises(NotADirectoryError) as e:
        with atomic_output(str(tmp_path / 'file' / 'out.bag')):
            pass
    assert atomic.error_line(e.value) == '%s: not a directory, cannot hold the output' % (tmp_path / 'file')


def test_text_json_and_figure_helpers_leave_only_the_file(tmp_path):
    atomic.write_text(str(tmp_path / 'a.md'), 'text')
    atomic.write_json(str(tmp_path / 'a.json'), {'x': 1}, indent=1)
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig = plt.figure()
    atomic.save_figure(fig, str(tmp_path / 'a.png'))
    atomic.save_figure(fig, str(tmp_path / 'noext'))
    plt.close(fig)
    assert sorted(os.listdir(str(tmp_path))) == ['a.json', 'a.md', 'a.png', 'noext']
    assert json.loads((tmp_path / 'a.json').read_text()) == {'x': 1}
    assert (tmp_path / 'noext').read_bytes()[:4] == b'\x89PNG'


@pytest.mark.parametrize('signum', [signal.SIGTERM, signal.SIGHUP], ids=lambda s: s.name)
def test_run_tool_turns_a_signal_into_a_clean_exit(tmp_path, capsys, signum):
    target = tmp_path / 'out.bag'
    before = signal.getsignal(signum)
    # As a terminal gives it: under nohup SIGHUP arrives ignored, and run_tool rightly keeps it so (tested below).
    signal.signal(signum, signal.SIG_DFL)

    def main():
        with atomic_output(str(target)) as tmp:
            with open(tmp, 'w') as f:
                f.write('half')
            os.kill(os.getpid(), signum)
            time.sleep(10)  # the handler raises before this ends
        return 0

    try:
        assert atomic.run_tool('tool', main) == 128 + signum
    finally:
        signal.signal(signum, before)
        del atomic._terminated[:]
    assert capsys.readouterr().err == 'tool: terminated by %s, nothing written\n' % signal.Signals(signum).name
    assert os.listdir(str(tmp_path)) == []


def test_run_tool_restores_the_handlers_and_keeps_an_ignored_sighup(capsys):
    term = signal.getsignal(signal.SIGTERM)
    old = signal.signal(signal.SIGHUP, signal.SIG_IGN)  # as under nohup
    try:
        seen = []
        assert atomic.run_tool('tool', lambda: seen.append(signal.getsignal(signal.SIGHUP)) or 3) == 3
        assert seen == [signal.SIG_IGN]
    finally:
        signal.signal(signal.SIGHUP, old)
    assert signal.getsignal(signal.SIGTERM) == term


def test_run_tool_reports_user_errors_in_one_line(capsys):
    def fail(error):
        raise error

    assert atomic.run_tool('tool', fail, FileNotFoundError(errno.ENOENT, 'No such file or directory', 'a b')) == 1
    assert atomic.run_tool('tool', fail, atomic.UserError('x.log:3: expected\nsomething')) == 1
    assert atomic.run_tool('tool', fail, ValueError('bad value'), errors=(ValueError,)) == 1
    assert capsys.readouterr().err == ('tool: a b: no such file or directory\ntool: x.log:3: expected something\n'
                                       'tool: bad value\n')
    with pytest.raises(ZeroDivisionError):  # a bug is not a user error: its traceback is kept
        atomic.run_tool('tool', lambda: 1 / 0)
