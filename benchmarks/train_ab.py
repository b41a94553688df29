"""Training A/B: a fixed-seed tiny training from two git revisions, compared by hash.

Each side (the base revision's ``src/``, exported with ``git archive``, and this
worktree's or ``--new DIR``'s) trains the same tiny top-down model in a fresh process
(one thread, deterministic algorithms) on the same synthetic frames, with a held-out
fifth of them evaluated every ``--eval-every`` steps, and prints the SHA-256 of the
saved weights (every tensor of the state dict, in order) and of the report without its
timings (every key with ``seconds``) and the output path.  The two lines must be equal.

Usage::

    python benchmarks/train_ab.py --base 662e3a3
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

CHILD = r"""
import hashlib, json, sys
import numpy as np
try:
    from thermoswarm.tracking.detect import unet
    from thermoswarm.tracking.train import fit as tr
except ImportError:  # the flat layout before the rooms (e33dc8e and older)
    from thermoswarm.tracking import unet
    from thermoswarm.tracking import train as tr
out = sys.argv[1]
small = unet.ModelConfig(centroid_channels=(8, 16, 16), pose_channels=(12, 16, 16))
data = tr.synthetic_data(tr.SynthDataConfig(n_videos=2, frames_per_video=3, width=400,
                                            height=160, codec=False),
                         np.random.default_rng(3))
cfg = tr.TrainConfig(max_steps={steps}, eval_every={every}, centroid_batch=2, patch_size=64,
                     pose_batch=8, val_fraction=0.2, model=small, threads=1, seed=5)
report = tr.train(data, out, cfg)
h = hashlib.sha256()
for k, v in unet.load_model(out).state_dict().items():
    h.update(k.encode()); h.update(v.detach().cpu().numpy().tobytes())
def strip(d):  # timings (every key with "seconds") and the output path differ
    if isinstance(d, dict):
        return {{k: strip(v) for k, v in d.items() if "seconds" not in k and k != "model"}}
    if isinstance(d, list):
        return [strip(v) for v in d]
    return d
r = hashlib.sha256(json.dumps(strip(report), sort_keys=True).encode()).hexdigest()
print(f"weights {{h.hexdigest()[:24]}} report {{r[:24]}} steps {{report['steps']}} "
      f"best {{report['best']['step']}}")
"""


def run_side(src: Path, workdir: Path, steps: int, every: int) -> str:
    env = dict(os.environ, PYTHONPATH=str(src))
    code = CHILD.format(steps=steps, every=every)
    proc = subprocess.run([sys.executable, "-c", code, str(workdir / "m.pt")], env=env,
                          capture_output=True, text=True)  # fmt: skip
    if proc.returncode:
        return "FAILED " + (proc.stdout + proc.stderr)[-800:]
    return proc.stdout.strip().splitlines()[-1]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", required=True, help="git revision of the base side")
    ap.add_argument("--new", type=Path, default=ROOT, help="root of the new side's checkout")
    ap.add_argument("--steps", type=int, default=6)
    ap.add_argument("--eval-every", type=int, default=3)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="train_ab_") as tmp:
        tmp = Path(tmp)
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", args.base, "src"],
                                 check=True, capture_output=True).stdout  # fmt: skip
        (tmp / "base").mkdir()
        subprocess.run(["tar", "-x", "-C", str(tmp / "base")], input=archive, check=True)
        lines = {}
        for side, src in (("base", tmp / "base" / "src"), ("new", args.new / "src")):
            work = tmp / f"run_{side}"
            work.mkdir()
            lines[side] = run_side(src, work, args.steps, args.eval_every)
            print(f"{side}: {lines[side]}", flush=True)
        same = lines["base"] == lines["new"] and not lines["base"].startswith("FAILED")
        print("identical" if same else "DIFFERENT")
        return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
