"""Synthetic ant videos with ground truth.

Ants walk on the paper's narrow wooden road (PAPER_NOTES section 3: a 40 mm wide section
and a 20 mm narrow section) under the paper's ant model, and are rendered top-down as
articulated head / mesosoma / gaster shapes with legs and antennae on a textured wooden
road, with slow lighting drift, flicker, a moving soft shadow, motion blur, optical
blur and sensor noise.  Ants touch and cross each other freely (they are not solid).

Motion (all units mm, s, rad)
-----------------------------
Each ant is in one of two phases: phase 1 ("liquid", ``kT1``) with probability ``phi``
and phase 2 ("gas", ``kT2``).  Its energy per unit mass ``E = v^2 / 2`` is drawn from
``Exponential(kT_phase)`` (:class:`thermoswarm.maxent.EnergyMixture` marginally) and its
speed is ``v = sqrt(2 E)``.  A speed draw is held for an exponential time of mean
``speed_tau_s`` and the phase is re-drawn (from ``Bernoulli(phi)``) at rate
``1 / phase_tau_s``, with a fresh speed when the phase changes; both are memoryless
renewals, so at every frame the energy is *exactly* distributed as the mixture
``phi Exp(kT1) + (1 - phi) Exp(kT2)``.  Every frame the heading turns at a rate ``w``
with ``|w| ~ Exponential(T_theta(v))`` (:class:`thermoswarm.maxent.SteeringLaw` with a
:class:`~thermoswarm.maxent.DecayingTemperature`); the sign turns towards the ant's
travel direction along the road with probability ``0.5 + goal_bias * min(1, |err| /
(pi/2))`` (``err`` = heading error), which keeps the traffic bidirectional without
changing the law of ``|w|``.  With ``p_k`` the body point in frame ``k``,
``p_{k+1} = p_k + v_k dt (cos h_k, sin h_k)`` and ``h_{k+1} = h_k + w_k dt``: the
displacement between frames ``k`` and ``k+1`` has length ``v_k dt`` and the change of
its direction is ``w_k dt``, so a tracker with perfect positions recovers ``v_k`` and
``w_k`` exactly (except at wall contacts, flagged in ``wall_contact``).

Walls reflect the heading (specular); an ant that leaves the road at an end is
replaced by a new ant (a new identity) entering at that end, so ``n_ants`` ants are on
the road at every frame.  The road runs along the frame's long axis; by default it is
as long as the frame (``road_length_mm = None``), its widths are in mm at
``px_per_mm`` (default the paper's 3.04 px/mm), and the narrow section is the last
``narrow_fraction`` of its length.

Randomness: :func:`generate` draws the motion, the appearance and one seed for the
per-frame noise from the caller's :class:`numpy.random.Generator`; frame ``k`` is
rendered with ``numpy.random.default_rng([render_seed, k])``, so frames can be rendered
in any order, and the same seed gives the same video.

Outputs
-------
:class:`SynthVideo` holds the ground truth -- ``keypoints`` ``(T, N, 3, 2)`` px [head,
body, tail] (NaN outside an ant's lifetime), the MOTChallenge GT table ``mot_gt`` and
``tracks``, the trajectory Dataset (mm in image coordinates, s) with extra variables
``speed`` (mm/s), ``steering_rate`` (rad/s), ``phase`` (1 or 2) and ``wall_contact`` --
and renders frames (RGB ``uint8``) lazily with :meth:`SynthVideo.frames`.
:func:`write_video` writes mp4 (imageio-ffmpeg) or a folder of PNG frames;
:func:`write_sequence` writes a MOTChallenge-style sequence folder.

Command line: ``python -m thermoswarm.tracking.synth OUT_DIR --seed 1 --set n_ants=40``.
"""

from __future__ import annotations

import io
import os
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from thermoswarm.config import dumps_toml
from thermoswarm.errors import InputError, OutputError
from thermoswarm.fsutil import (
    atomic_path,
    atomic_write_bytes,
    atomic_write_text,
    prepare_output_dir,
)
from thermoswarm.tracking import anatomy
from thermoswarm.tracking.synth.motion import Road, SynthConfig, _simulate, _skeleton
from thermoswarm.tracking.synth.render import SynthVideo, _lighting, _mot_gt
from thermoswarm.tracks import make_tracks

__all__ = [
    "SynthConfig",
    "Road",
    "SynthVideo",
    "generate",
    "write_video",
    "write_sequence",
]


def generate(
    config: SynthConfig | None = None,
    rng: np.random.Generator | int | None = None,
) -> SynthVideo:
    """Simulate ants on the road and prepare their video.

    Parameters
    ----------
    config
        :class:`SynthConfig` (default: 40 ants, 300 frames, 1920x1080 at 30 fps).
    rng
        A :class:`numpy.random.Generator` (or an integer seed).  The motion, the
        appearance and the per-frame noise all flow from it.

    Returns
    -------
    SynthVideo
        Ground truth (keypoints px, MOT GT table, trajectory Dataset in mm and s) and a
        lazy renderer of the frames.
    """
    cfg = config or SynthConfig()
    if not isinstance(rng, np.random.Generator):
        if rng is None:
            raise TypeError("generate() needs a numpy Generator or an integer seed")
        rng = np.random.default_rng(rng)
    road = cfg.road
    motion = _simulate(cfg, road, rng)
    lighting = _lighting(cfg, rng)
    texture_seed = int(rng.integers(2**63))
    render_seed = int(rng.integers(2**63))
    geom = _skeleton(cfg, road, motion)
    kp = geom["keypoints"]
    N = kp.shape[1]
    ids = np.arange(1, N + 1)
    pad = 0.5 * cfg.ant_width_mm * cfg.px_per_mm
    gt = _mot_gt(kp, ids, pad, cfg.width, cfg.height)
    pos_mm = kp.transpose(0, 3, 2, 1) / cfg.px_per_mm  # (T, 2, 3, N)
    ds = make_tracks(
        pos_mm,
        fps=cfg.fps,
        individuals=[f"ant_{i}" for i in ids],
        keypoints=list(anatomy.KEYPOINTS),
        source_software=__package__,  # "thermoswarm.tracking.synth", as before the rooms
        attrs={
            "px_per_mm": cfg.px_per_mm,
            "frame_width": cfg.width,
            "frame_height": cfg.height,
            "ground_truth": 1,
        },
    )
    dims = ("time", "individuals")
    ds["speed"] = (
        dims,
        motion.speed,
        {"units": "mm/s", "long_name": "true speed of the step to the next frame"},
    )
    ds["steering_rate"] = (
        dims,
        motion.rate,
        {"units": "rad/s", "long_name": "true heading rate of that step"},
    )
    ds["phase"] = (dims, motion.phase, {"long_name": "1 liquid (kT1), 2 gas (kT2), 0 absent"})
    ds["wall_contact"] = (dims, motion.wall, {"long_name": "step reflected by a wall"})
    return SynthVideo(cfg, kp, ids, gt, ds, geom, motion, lighting, render_seed, texture_seed)


# --------------------------------------------------------------------------- writing

_MUXERS = {".mp4": "mp4", ".avi": "avi", ".mkv": "matroska", ".mov": "mov"}


def write_video(
    frames: Iterable[np.ndarray],
    path: str | os.PathLike,
    fps: float,
    *,
    quality: int = 6,
    codec: str = "libx264",
) -> Path:
    """Write RGB uint8 frames to a video file or a folder of PNG frames, atomically.

    A path ending in ``.mp4``/``.avi``/``.mkv``/``.mov`` is encoded with imageio-ffmpeg
    (``codec``, ``quality`` 0-10, 6 = x264 CRF 20, yuv420p, a key frame every second);
    any other path becomes a folder of
    ``000001.png``, ``000002.png``, ... (the MOTChallenge ``img1`` layout).
    """
    import cv2

    path = Path(path)
    if not path.absolute().parent.is_dir():
        raise OutputError(f"{path}: parent directory does not exist")
    if path.suffix.lower() in _MUXERS:
        import imageio_ffmpeg

        with atomic_path(path, suffix=path.suffix) as tmp:
            writer = None
            try:
                for frame in frames:
                    if writer is None:
                        h, w = frame.shape[:2]
                        writer = imageio_ffmpeg.write_frames(
                            str(tmp),
                            (w, h),
                            fps=fps,
                            codec=codec,
                            quality=quality,
                            pix_fmt_in="rgb24",
                            pix_fmt_out="yuv420p",
                            macro_block_size=1,
                            ffmpeg_log_level="error",
                            output_params=[
                                "-g",
                                str(max(int(round(fps)), 1)),
                                "-f",
                                _MUXERS[path.suffix.lower()],
                            ],
                        )
                        writer.send(None)
                    writer.send(np.ascontiguousarray(frame))
            finally:
                if writer is not None:
                    writer.close()
            if writer is None:
                raise InputError(f"{path}: no frames to write")
        return path
    with atomic_path(path) as tmp:
        tmp.mkdir()
        for k, frame in enumerate(frames, 1):
            bgr = cv2.cvtColor(frame, cv2.COLOR_RGB2BGR) if frame.ndim == 3 else frame
            if not cv2.imwrite(str(tmp / f"{k:06d}.png"), bgr):
                raise OutputError(f"{path}: could not write frame {k}")
    return path


def write_sequence(
    video: SynthVideo, out_dir: str | os.PathLike, *, video_format: str = "mp4"
) -> Path:
    """Write a MOTChallenge-style sequence folder.

    ``out_dir/video.mp4`` (or ``img1/`` PNG frames with ``video_format="frames"``),
    ``gt/gt.txt`` (MOT GT, body-centred boxes), ``gt/keypoints.npz`` (``keypoints``
    ``(T, N, 3, 2)`` px [head, body, tail], NaN when absent; ``ids`` ``(N,)`` the MOT
    ids; ``keypoint_names``), ``gt_tracks.nc`` (trajectory format with
    the true speeds, rates and phases), ``seqinfo.ini`` and ``synth.toml`` (the config).
    """
    from thermoswarm.io.mot import write_mot_table
    from thermoswarm.io.netcdf import write as write_nc

    if video_format not in ("mp4", "frames"):
        raise InputError(f"video_format must be 'mp4' or 'frames', got {video_format!r}")
    out = prepare_output_dir(out_dir)
    cfg = video.config
    (out / "gt").mkdir(exist_ok=True)
    write_mot_table(out / "gt" / "gt.txt", video.mot_gt)
    buf = io.BytesIO()
    np.savez_compressed(
        buf, keypoints=video.keypoints, ids=video.ids, keypoint_names=np.array(anatomy.KEYPOINTS)
    )
    atomic_write_bytes(out / "gt" / "keypoints.npz", buf.getvalue())
    write_nc(video.tracks, out / "gt_tracks.nc")
    atomic_write_text(out / "synth.toml", dumps_toml(cfg))
    target = out / ("video.mp4" if video_format == "mp4" else "img1")
    write_video(video.frames(), target, cfg.fps)
    atomic_write_text(
        out / "seqinfo.ini",
        (
            "[Sequence]\n"
            f"name={out.name}\nimDir=img1\nframeRate={cfg.fps:g}\nseqLength={cfg.n_frames}\n"
            f"imWidth={cfg.width}\nimHeight={cfg.height}\nimExt=.png\n"
        ),
    )
    return out


def _main() -> None:  # pragma: no cover - thin CLI, exercised by hand
    import click

    from thermoswarm.config import apply_overrides, from_mapping, parse_overrides, to_dict
    from thermoswarm.errors import ThermoswarmError

    @click.command()
    @click.argument("out_dir", type=click.Path(file_okay=False))
    @click.option("--seed", type=int, required=True, help="Seed of the random generator.")
    @click.option(
        "--format",
        "video_format",
        type=click.Choice(["mp4", "frames"]),
        default="mp4",
        show_default=True,
        help="Video as mp4 or PNG folder.",
    )
    @click.option(
        "--set",
        "overrides",
        multiple=True,
        metavar="KEY=VALUE",
        help="Any SynthConfig field, e.g. --set n_ants=40 --set width=1920.",
    )
    def main(out_dir: str, seed: int, video_format: str, overrides: tuple[str, ...]) -> None:
        """Write a synthetic ant video with MOTChallenge ground truth to OUT_DIR."""
        try:
            data = apply_overrides(to_dict(SynthConfig()), parse_overrides(overrides))
            cfg = from_mapping(SynthConfig, data, source="--set")
            video = generate(cfg, np.random.default_rng(seed))
            out = write_sequence(video, out_dir, video_format=video_format)
        except ThermoswarmError as exc:
            click.echo(f"error: {exc}", err=True)
            raise SystemExit(exc.exit_code) from None
        click.echo(
            f"wrote {out} ({cfg.n_ants} ants on the road at a time, {video.ids.size} "
            f"over the video as ants leave and enter; {cfg.n_frames} frames)"
        )

    main()


if __name__ == "__main__":  # pragma: no cover
    _main()
