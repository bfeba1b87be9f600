"""Write configs/sample.toml from a simulated scenario.toml, with paths relative to configs/."""
from __future__ import annotations

import re
import sys
from pathlib import Path


def main(src: str, dst: str) -> None:
    src_p, dst_p = Path(src).resolve(), Path(dst).resolve()
    rel = Path("..") / src_p.parent.relative_to(dst_p.parent.parent)
    text = src_p.read_text()
    text = re.sub(r'^file = "([^"]+)"', lambda m: f'file = "{(rel / m.group(1)).as_posix()}"',
                  text, flags=re.MULTILINE)
    text = re.sub(r'^dir = "([^"]+)"', 'dir = "../out/sample"', text, flags=re.MULTILINE)
    dst_p.write_text(text)


if __name__ == "__main__":
    main(*sys.argv[1:3])
