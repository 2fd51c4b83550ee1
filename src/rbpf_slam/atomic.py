"""Atomic output files: a converter never leaves a half-written bag behind."""
import contextlib
import os


@contextlib.contextmanager
def atomic_output(path):
    """Yield a temporary path beside ``path``; rename it to ``path`` only if the block completes.

    On any exception, KeyboardInterrupt included, the temporary file is removed and ``path`` is left
    as it was (an existing file is not touched). The temporary file is in the same directory, so the
    final rename is atomic on POSIX file systems.
    """
    path = os.path.abspath(path)
    directory = os.path.dirname(path)
    if not os.path.isdir(directory):
        raise FileNotFoundError('output directory does not exist: %s' % directory)
    base, ext = os.path.splitext(os.path.basename(path))
    tmp = os.path.join(directory, '.%s.partial-%d%s' % (base, os.getpid(), ext))
    try:
        yield tmp
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise
    if not os.path.exists(tmp):
        raise RuntimeError('nothing was written to %s' % tmp)
    os.replace(tmp, path)
