"""Reading videos (files or folders of frames) and writing overlay videos.

:func:`open_video` returns a :class:`VideoSource` for a video file (decoded by OpenCV's
FFmpeg backend) or a folder of images (``.png``, ``.jpg``, ``.jpeg``, ``.tif``,
``.tiff``, ``.bmp``, sorted by name).  Frames are RGB ``uint8`` ``(H, W, 3)``.  A file
that cannot be opened or decoded is an :class:`~thermoswarm.errors.InputError` naming
it.  :meth:`VideoSource.frames` can decode in a background thread (``prefetch``), so
that decoding overlaps with detection on a second core: OpenCV releases the GIL.

:class:`OverlayWriter` writes annotated frames to an mp4 (imageio-ffmpeg, in its own
process) or a folder of PNG frames, atomically (a temporary name until closed).
"""

from __future__ import annotations

import math
import os
import queue
import threading
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from thermoswarm.errors import InputError, OutputError

__all__ = ["VideoSource", "open_video", "OverlayWriter", "IMAGE_EXTS"]

# FFmpeg's own messages ("moov atom not found", ...) would come before our one-line
# error; OpenCV reads this when its FFmpeg backend first opens a file.  A user's own
# setting wins.
os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")

IMAGE_EXTS = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp")


#: Smallest frame side (px) anything can be detected in, and most pixels of a frame.
MIN_SIDE = 8
MAX_PIXELS = 2**30
#: Frames apart beyond which ``frames`` seeks instead of decoding every frame between
#: (a seek decodes from the key frame before: up to 250 frames with x264's defaults).
SEEK_STEP = 250


def _check_frame_size(img: np.ndarray, where: Path) -> np.ndarray:
    """``img`` if its sides are at least :data:`MIN_SIDE` px and it has at most
    :data:`MAX_PIXELS` pixels; else a one-line InputError naming ``where``."""
    h, w = img.shape[:2]
    if min(w, h) < MIN_SIDE or w * h > MAX_PIXELS:
        raise InputError(
            f"{where}: a {w}x{h} px frame; expected sides of at least {MIN_SIDE} px and "
            f"at most {MAX_PIXELS:,} pixels"
        )
    return img


class VideoSource:
    """A video file or a folder of frames.

    Attributes
    ----------
    path
        The file or folder.
    fps
        Frame rate from the file's metadata (``None`` when unknown, e.g. a folder).
    n_frames
        Number of frames if known (a folder; a file's header may be inexact).
    size
        ``(width, height)`` px.
    """

    def __init__(self, path: str | os.PathLike) -> None:
        import cv2

        self.path = Path(path)
        if not self.path.exists():
            raise InputError(f"{self.path}: no such file or directory")
        self._files: list[Path] | None = None
        if self.path.is_dir():
            files = sorted(p for p in self.path.iterdir() if p.suffix.lower() in IMAGE_EXTS)
            if not files:
                raise InputError(
                    f"{self.path}: folder holds no image frames ({', '.join(IMAGE_EXTS)})"
                )
            self._files = files
            first = self._read_image(files[0])
            self.size = (first.shape[1], first.shape[0])
            self.fps: float | None = None
            self.n_frames: int | None = len(files)
            return
        cap = cv2.VideoCapture(str(self.path))
        try:
            if not cap.isOpened():
                raise InputError(
                    f"{self.path}: cannot open as a video (unreadable, corrupt or "
                    "not a video file)"
                )
            ok, frame = cap.read()
            if not ok or frame is None:
                raise InputError(f"{self.path}: no frame could be decoded (corrupt video?)")
            self.size = (frame.shape[1], frame.shape[0])
            _check_frame_size(frame, self.path)
            fps = cap.get(cv2.CAP_PROP_FPS)
            self.fps = float(fps) if fps and math.isfinite(fps) and 0 < fps < 10000 else None
            n = int(cap.get(cv2.CAP_PROP_FRAME_COUNT) or 0)
            self.n_frames = n if n > 0 else None
        finally:
            cap.release()

    @classmethod
    def from_images(cls, files: list[Path], name: str = "images") -> VideoSource:
        """A sequence of image files (in the order given) read as one video; all must
        have the first one's size."""
        if not files:
            raise InputError(f"{name}: no image files")
        self = cls.__new__(cls)
        self.path = Path(name)
        self._files = [Path(f) for f in files]
        first = self._read_image(self._files[0])
        self.size = (first.shape[1], first.shape[0])
        self.fps = None
        self.n_frames = len(self._files)
        return self

    @property
    def files(self) -> list[Path] | None:
        """The image files of a folder or image sequence (None for a video file)."""
        return None if self._files is None else list(self._files)

    def _read_image(self, p: Path) -> np.ndarray:
        import cv2

        try:
            img = cv2.imread(str(p), cv2.IMREAD_COLOR)
        except cv2.error:  # e.g. a header declaring more pixels than OpenCV decodes
            img = None
        if img is None:
            raise InputError(
                f"{p}: cannot read image frame (unreadable, corrupt, or larger than "
                f"{MAX_PIXELS:,} pixels)"
            )
        return cv2.cvtColor(_check_frame_size(img, p), cv2.COLOR_BGR2RGB)

    def _iter(self, stop: int | None, step: int = 1, start: int = 0) -> Iterator[np.ndarray]:
        import cv2

        if self._files is not None:
            for k, p in enumerate(self._files):
                if stop is not None and k >= stop:
                    return
                if k < start or (k - start) % step:
                    continue
                img = self._read_image(p)
                if (img.shape[1], img.shape[0]) != self.size:
                    raise InputError(
                        f"{p}: frame size {img.shape[1]}x{img.shape[0]} differs "
                        f"from the first frame's {self.size[0]}x{self.size[1]}"
                    )
                yield img
            return
        cap = cv2.VideoCapture(str(self.path))
        if not cap.isOpened():
            raise InputError(f"{self.path}: cannot open as a video")
        try:
            k = 0
            if start > 0:  # a seek (to the key frame before, then decoded forward)
                cap.set(cv2.CAP_PROP_POS_FRAMES, start)
                k = start
            while stop is None or k < stop:
                if (k - start) % step:
                    if step > SEEK_STEP:  # far apart: a seek decodes fewer frames
                        k += step - (k - start) % step
                        if stop is not None and k >= stop:
                            return
                        cap.set(cv2.CAP_PROP_POS_FRAMES, k)
                        continue
                    # Skipped frames are decoded (grab) but not converted.
                    if not cap.grab():
                        return
                    k += 1
                    continue
                ok, frame = cap.read()
                if not ok or frame is None:
                    return
                if (frame.shape[1], frame.shape[0]) != self.size:
                    raise InputError(f"{self.path}: frame {k + 1} has a different size")
                yield cv2.cvtColor(frame, cv2.COLOR_BGR2RGB)
                k += 1
        finally:
            cap.release()

    def frames(
        self, stop: int | None = None, *, step: int = 1, prefetch: int = 0, start: int = 0
    ) -> Iterator[np.ndarray]:
        """Frames ``start, start + step, ...`` below ``stop`` (RGB uint8), decoded ahead
        in a thread if ``prefetch`` > 0 (that many frames are buffered)."""
        if step < 1 or start < 0:
            raise ValueError(f"step must be positive and start >= 0, got {step}, {start}")
        if prefetch <= 0:
            yield from self._iter(stop, step, start)
            return
        q: queue.Queue = queue.Queue(maxsize=prefetch)
        done = object()
        stop_flag = threading.Event()

        def work() -> None:
            try:
                for f in self._iter(stop, step, start):
                    while not stop_flag.is_set():
                        try:
                            q.put(f, timeout=0.1)
                            break
                        except queue.Full:
                            continue
                    if stop_flag.is_set():
                        return
                q.put(done)
            except BaseException as exc:  # handed to the consumer
                q.put(exc)

        th = threading.Thread(target=work, name="thermoswarm-decode", daemon=True)
        th.start()
        try:
            while True:
                item = q.get()
                if item is done:
                    return
                if isinstance(item, BaseException):
                    raise item
                yield item
        finally:
            stop_flag.set()
            th.join(timeout=5)


def open_video(path: str | os.PathLike) -> VideoSource:
    """Open a video file or a folder of frames (see :class:`VideoSource`)."""
    return VideoSource(path)


_COLOURS = np.array([
    (230, 25, 75), (60, 180, 75), (255, 225, 25), (0, 130, 200), (245, 130, 48),
    (145, 30, 180), (70, 240, 240), (240, 50, 230), (210, 245, 60), (250, 190, 212),
    (0, 128, 128), (220, 190, 255), (170, 110, 40), (255, 250, 200), (128, 0, 0),
    (170, 255, 195), (128, 128, 0), (255, 215, 180), (0, 0, 128), (255, 255, 255),
])  # fmt: skip


class OverlayWriter:
    """Draws tracks on frames and writes them (mp4 or PNG folder), atomically.

    Parameters
    ----------
    path
        ``*.mp4`` (imageio-ffmpeg, libx264) or a folder name.
    fps
        Frame rate of the output.
    scale
        Output size relative to the input frames (0.5 halves both sides).
    trail
        Frames of trail drawn behind each ant.
    """

    def __init__(
        self, path: str | os.PathLike, fps: float, *, scale: float = 0.5, trail: int = 15
    ) -> None:
        if not (0 < scale <= 1):
            raise InputError(f"overlay scale must be in (0, 1], got {scale!r}")
        self.path = Path(path)
        self.fps = fps
        self.scale = scale
        self.trail = trail
        self._tmp = self.path.with_name(f".{self.path.name}.part{self.path.suffix}")
        self._writer = None
        self._k = 0
        self._hist: dict[int, list[np.ndarray]] = {}
        self._mp4 = self.path.suffix.lower() == ".mp4"
        if not self._mp4:
            self._tmp.mkdir(exist_ok=True)

    def shrink(self, frame: np.ndarray) -> np.ndarray:
        """The frame at the output size (even width and height)."""
        import cv2

        h, w = frame.shape[:2]
        size = (
            max(int(round(w * self.scale)) // 2 * 2, 2),
            max(int(round(h * self.scale)) // 2 * 2, 2),
        )
        if size == (w, h):
            return frame.copy()
        return cv2.resize(frame, size, interpolation=cv2.INTER_AREA)

    def write(
        self,
        frame: np.ndarray,
        rows: list[tuple[int, np.ndarray, np.ndarray]],
        *,
        shrunk: bool = False,
    ) -> None:
        """Annotate one RGB frame with ``rows`` of ``(id, points (3, 2), box (4,))`` px
        of the full frame; ``shrunk`` says the frame already went through
        :meth:`shrink`."""
        import cv2

        s = self.scale
        img = frame if shrunk else self.shrink(frame)
        seen = set()
        for ident, pts, box in rows:
            col = tuple(int(c) for c in _COLOURS[ident % len(_COLOURS)])
            seen.add(ident)
            x0, y0, bw, bh = (box * s).tolist()
            cv2.rectangle(img, (int(x0), int(y0)), (int(x0 + bw), int(y0 + bh)), col, 1)
            body = pts[1] * s
            trail = self._hist.setdefault(ident, [])
            trail.append(body)
            del trail[: -self.trail]
            if len(trail) > 1:
                cv2.polylines(img, [np.round(np.array(trail)).astype(np.int32)], False, col, 1)
            for j, kc in enumerate(((0, 255, 0), (255, 255, 0), (0, 80, 255))):
                if np.all(np.isfinite(pts[j])):
                    c = np.round(pts[j] * s).astype(int)
                    cv2.circle(img, (int(c[0]), int(c[1])), 2, kc, -1)
            cv2.putText(
                img,
                str(ident),
                (int(x0), max(int(y0) - 2, 8)),
                cv2.FONT_HERSHEY_SIMPLEX,
                0.35,
                col,
                1,
                cv2.LINE_AA,
            )
        for gone in [i for i in self._hist if i not in seen]:
            del self._hist[gone]
        self._k += 1
        if self._mp4:
            if self._writer is None:
                import imageio_ffmpeg

                h, w = img.shape[:2]
                self._writer = imageio_ffmpeg.write_frames(
                    str(self._tmp),
                    (w, h),
                    fps=self.fps,
                    codec="libx264",
                    quality=5,
                    pix_fmt_in="rgb24",
                    macro_block_size=2,
                    ffmpeg_log_level="error",
                    output_params=["-preset", "ultrafast", "-f", "mp4"],
                )
                self._writer.send(None)
            self._writer.send(np.ascontiguousarray(img))
        else:
            if not cv2.imwrite(
                str(self._tmp / f"{self._k:06d}.png"), cv2.cvtColor(img, cv2.COLOR_RGB2BGR)
            ):
                raise OutputError(f"{self.path}: could not write frame {self._k}")

    def close(self) -> Path:
        """Finish the file and move it into place."""
        import shutil

        if self._writer is not None:
            self._writer.close()
            self._writer = None
        if self._k == 0:
            self.abort()
            raise InputError(f"{self.path}: no frames to write")
        if self.path.is_dir() and not self.path.is_symlink():
            shutil.rmtree(self.path)
        os.replace(self._tmp, self.path)
        return self.path

    def abort(self) -> None:
        """Drop the partial output."""
        import contextlib
        import shutil

        if self._writer is not None:
            with contextlib.suppress(Exception):
                self._writer.close()
            self._writer = None
        if self._tmp.is_dir():
            shutil.rmtree(self._tmp, ignore_errors=True)
        else:
            with contextlib.suppress(FileNotFoundError):
                self._tmp.unlink()
