"""core/array_io.py: the compiled text writer gives ``format_rows``' text
(np.savetxt's ``%.9f``) byte for byte: random values over every magnitude,
values a hair from a rounding tie, signed zeros, NaN, inf, subnormals and
the 2^22 bound where Python takes over."""
import numpy as np
import pytest

from hyper_nav_workbench.core import array_io


def _cases():
    rng = np.random.default_rng(41)
    out = [rng.normal(0.0, s, (500, 11)) for s in (1e-12, 1e-9, 1e-6, 1e-3, 1.0, 1e3, 1e5, 4e6, 5e6, 1e9, 1e20)]
    for lo, hi in ((-2.0, 2.0), (-5e6, 5e6)):          # within an ulp or so of a tie at the 9th decimal
        out.append((np.round(rng.uniform(lo, hi, (500, 11)) * 1e9) + 0.5) / 1e9)
    out.append(np.array([[0.0, -0.0, np.nan, -np.nan, np.inf, -np.inf, 5e-324, -5e-324, 0.9999999995,
                          4194303.9999999995, 4194304.0],
                         [1e-9, 5e-10, -5e-10, 1.5e-9, 2.5e-9, 0.1, 0.125, 456300.005, -456300.005, 1e-300,
                          2.0 ** 22 - 1e-9]]))
    out.append(np.array([[456300.0 + k * 0.005, -k * 1e-7, 30.0 + k * 1e-9] for k in range(2000)]))
    return out


@pytest.mark.parametrize("precision", [9, 3, 0])
def test_compiled_text_is_format_rows_byte_for_byte(precision):
    for rows in _cases():
        assert array_io.format_rows_compiled(rows, precision) == array_io.format_rows(rows, precision).encode()


def test_write_rows_writes_savetxt_text(tmp_path):
    rows = np.vstack(_cases()[-3:-1])
    np.savetxt(tmp_path / "ref.txt", rows, fmt="%.9f", delimiter=" ")
    array_io.write_rows(tmp_path / "new.txt", rows)
    assert (tmp_path / "new.txt").read_bytes() == (tmp_path / "ref.txt").read_bytes()
    assert array_io.format_rows_compiled(np.zeros((0, 3))) == b""
