"""The README's code examples run as printed (with this build's folder for `build/`)."""
import re

from conftest import ROOT
from fmu_host import fmu_dir


def python_blocks(section):
    """The ```python blocks of a README section (from its heading to the next heading of its level)."""
    text = (ROOT / "README.md").read_text()
    start = text.index(f"\n## {section}")
    end = text.find("\n## ", start + 1)
    return re.findall(r"```python\n(.*?)```", text[start:end if end > 0 else None], re.S)


def test_fmu_example_runs(grains_bin):
    (block,) = python_blocks("FMU (co-simulation units)")
    code = block.replace('"build/fmus/', f'"{fmu_dir()}/')
    lines = code.rstrip().splitlines()
    namespace = {}
    exec("\n".join(lines[:-1]), namespace)
    fraction, virial = eval(lines[-1], namespace)   # the example's last line: the values it shows
    assert 0 < fraction <= 1 and virial > 0
    assert len(namespace["r"]) == 31   # stop time 2 in intervals of 100 dt = 100 * 0.02 / 30, plus t = 0
