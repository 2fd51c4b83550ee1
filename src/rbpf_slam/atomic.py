"""Atomic outputs and clean exits: a tool writes each output completely or not at all.

* :func:`atomic_output` writes beside the target under a hidden temporary name and renames it at the
  end; an exception (Ctrl-C, SIGTERM or SIGHUP included, see :func:`run_tool`) removes the temporary file.
* :func:`run_tool` runs a command's ``main``: SIGTERM / SIGHUP become :class:`Terminated`, which unwinds
  through every ``atomic_output`` like Ctrl-C; a user error (:class:`UserError`, an OSError) is one line
  ``tool: PATH: reason`` on stderr, never a traceback.
* :func:`run_child` runs another tool and passes such a signal on to it, so that it cleans up too.
"""
import contextlib
import errno
import json
import os
import signal
import subprocess
import sys

#: Signals that end a tool cleanly (outputs removed, exit code 128 + signal number).
TERMINATING_SIGNALS = (signal.SIGTERM, signal.SIGHUP)


class UserError(Exception):
    """A problem with the input, the output path or the command line: reported in one line."""


class Terminated(BaseException):
    """SIGTERM or SIGHUP arrived (a BaseException, like KeyboardInterrupt, so ``except Exception`` lets it pass)."""

    def __init__(self, signum):
        self.signum = signum
        super().__init__(signal.Signals(signum).name)


def _os_error(code, path, reason):
    return OSError(code, reason, path)  # Python makes it the subclass of the code (FileNotFoundError, ...)


def check_output(path):
    """Raise an OSError naming the problem unless a file can be created at ``path``: its folder exists and is
    a folder, and ``path`` is not a directory."""
    path = os.path.abspath(path)
    directory = os.path.dirname(path)
    if os.path.isdir(path):
        raise _os_error(errno.EISDIR, path, 'is a directory, not an output file')
    if not os.path.isdir(directory):
        if os.path.exists(directory):
            raise _os_error(errno.ENOTDIR, directory, 'not a directory, cannot hold the output')
        raise _os_error(errno.ENOENT, directory, 'the output folder does not exist')
    return path


@contextlib.contextmanager
def atomic_output(path):
    """Yield a temporary path beside ``path``; rename it to ``path`` only if the block completes.

    On any exception, KeyboardInterrupt and Terminated included, the temporary file is removed and ``path``
    is left as it was (an existing file is not touched). The temporary file is in the same directory, so
    the final rename is atomic on POSIX file systems. An OSError about the temporary file (permission
    denied, disk full, ...) is reported with ``path`` as its file name.
    """
    path = check_output(path)
    directory = os.path.dirname(path)
    base, ext = os.path.splitext(os.path.basename(path))
    tmp = os.path.join(directory, '.%s.partial-%d%s' % (base, os.getpid(), ext))
    try:
        yield tmp
        if not os.path.exists(tmp):
            raise RuntimeError('nothing was written to %s' % tmp)
        os.replace(tmp, path)
    except BaseException as e:
        if os.path.lexists(tmp):
            os.remove(tmp)
        if isinstance(e, OSError) and e.filename in (tmp, None) and e.errno is not None:
            e.filename, e.filename2 = path, None
        raise


def write_text(path, text):
    """Write a text file atomically."""
    with atomic_output(path) as tmp:
        with open(tmp, 'w') as f:
            f.write(text)


def write_bytes(path, data):
    """Write a binary file atomically."""
    with atomic_output(path) as tmp:
        with open(tmp, 'wb') as f:
            f.write(data)


def write_json(path, data, **kwargs):
    """Write ``data`` as JSON atomically (``kwargs`` as for json.dump)."""
    write_text(path, json.dumps(data, **kwargs) + '\n')


def save_figure(fig, path, **kwargs):
    """fig.savefig(path) atomically; the format is the file's extension (PNG without one)."""
    kwargs.setdefault('format', os.path.splitext(path)[1][1:] or 'png')
    with atomic_output(path) as tmp:
        fig.savefig(tmp, **kwargs)


def run_child(cmd, check=False, **kwargs):
    """subprocess.run(cmd, check, **kwargs), except that on Terminated the signal is passed on to the child,
    which is given 30 s to remove its own partial outputs (then killed) before Terminated goes on."""
    with subprocess.Popen(cmd, **kwargs) as proc:
        try:
            out, err = proc.communicate()
        except Terminated as e:
            proc.send_signal(e.signum)
            try:
                proc.communicate(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
            raise
    if check and proc.returncode:
        raise subprocess.CalledProcessError(proc.returncode, cmd, out, err)
    return subprocess.CompletedProcess(cmd, proc.returncode, out, err)


def error_line(error):
    """One line for an error: ``PATH: reason`` for an OSError with a file name, else its text."""
    if isinstance(error, OSError) and error.filename is not None and error.strerror:
        reason = error.strerror[:1].lower() + error.strerror[1:]
        where = str(error.filename) + (' -> %s' % error.filename2 if error.filename2 is not None else '')
        text = '%s: %s' % (where, reason)
    else:
        text = str(error) or type(error).__name__
    return ' '.join(text.split())


_terminated = []  # the signal that is ending the tool, once one came


def _terminate(signum, frame):
    if _terminated:  # a second signal must not interrupt the clean-up after the first
        return
    _terminated.append(signum)
    raise Terminated(signum)


def run_tool(prog, main, *args, errors=(), nothing='nothing written'):
    """Run ``main(*args)`` as the command ``prog`` and return its exit code.

    While it runs, SIGTERM and SIGHUP (unless ignored, e.g. under nohup) raise Terminated, once: later ones
    are ignored, and after one the handlers stay so until the process exits. Exit codes:
    ``main``'s own; 1 and ``prog: message`` for a UserError, an OSError or one of ``errors`` (the tool's
    own user errors, e.g. ValueError of a malformed input file); 130 after Ctrl-C; 128 + the signal
    number after SIGTERM / SIGHUP. ``nothing``: what the interrupt message says was written.
    """
    previous = {}
    del _terminated[:]
    try:
        for s in TERMINATING_SIGNALS:
            if signal.getsignal(s) == signal.SIG_DFL:
                previous[s] = signal.signal(s, _terminate)
    except ValueError:  # not the main thread: signals stay as they are
        pass
    try:
        return main(*args)
    except Terminated as e:
        sys.stderr.write('%s: terminated by %s, %s\n' % (prog, e, nothing))
        return 128 + e.signum
    except KeyboardInterrupt:
        sys.stderr.write('\n%s: interrupted, %s\n' % (prog, nothing))
        return 130
    except (UserError, OSError) + tuple(errors) as e:
        sys.stderr.write('%s: %s\n' % (prog, error_line(e)))
        return 1
    finally:
        if not _terminated:
            for s, handler in previous.items():
                signal.signal(s, handler)
