"""`flexmb.read_csv` on files it did not write: only `FlexmbError`s come out (issue 20, class 4)."""

import pytest

import flexmb
from flexmb.errors import ParameterError


def test_a_latin_1_file_is_a_parameter_error(tmp_path):
    """A spreadsheet saved in Latin-1 (main: raw UnicodeDecodeError)."""
    path = tmp_path / "t.csv"
    path.write_bytes("name,force\nbr\xfccke,1.5\n".encode("latin-1"))
    with pytest.raises(ParameterError, match="not UTF-8 text"):
        flexmb.read_csv(path)


def test_a_field_over_the_csv_limit_is_a_parameter_error(tmp_path):
    """A field of 131073 characters, over csv's default limit (main: raw _csv.Error)."""
    path = tmp_path / "t.csv"
    path.write_text("note,x\n" + "a" * 131_073 + ",1\n")
    with pytest.raises(ParameterError, match=r"line 2: not readable CSV .*field_size_limit"):
        flexmb.read_csv(path)


@pytest.mark.skipif(not hasattr(__import__("os"), "mkfifo"), reason="POSIX FIFOs")
def test_a_fifo_or_folder_is_refused_without_blocking(tmp_path):
    import os

    os.mkfifo(tmp_path / "pipe.csv")
    with pytest.raises(ParameterError, match="not a regular file"):
        flexmb.read_csv(tmp_path / "pipe.csv")
    with pytest.raises(ParameterError, match="not a regular file"):
        flexmb.read_csv(tmp_path)


def test_utf_8_text_round_trips(tmp_path):
    table = flexmb.Table({"name": ["brücke", "µm"], "x": [1.5, 2.5]})
    back = flexmb.read_csv(table.to_csv(tmp_path / "t.csv"))
    assert list(back["name"]) == ["brücke", "µm"] and list(back["x"]) == [1.5, 2.5]
