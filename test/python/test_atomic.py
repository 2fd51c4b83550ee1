import os

import pytest

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
