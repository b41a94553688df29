"""Frames of a source video, decoded on the server one at a time, sent as JPEG.

OpenCV decodes (it is in the ``track`` and ``video`` extras, which ``track`` needs
anyway).  A video file is read sequentially while the page plays and sought
(``CAP_PROP_POS_FRAMES``) when it jumps; a folder of frames is read by index.  One lock
serialises the decoder: the server answers frame requests from several threads.
"""

from __future__ import annotations

import os
import threading
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.errors import InputError

__all__ = ["VideoFrames"]

_IMAGE_EXTS = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")
#: Frames wider than this are sent shrunk (the page scales them back to video px).
_MAX_WIDTH = 1600


class VideoFrames:
    """Random access to the frames of a video file or a folder of images.

    Parameters
    ----------
    path
        Video file (anything OpenCV opens) or a folder of image frames.
    """

    def __init__(self, path: str | os.PathLike) -> None:
        try:
            import cv2
        except ImportError:
            raise InputError(
                "showing video frames needs OpenCV: pip install 'thermoswarm[video]'"
            ) from None
        self._cv2 = cv2
        self.path = Path(path)
        self._lock = threading.Lock()
        self._files: list[Path] | None = None
        self._cap: Any = None
        self._next = 0
        if self.path.is_dir():
            files = sorted(p for p in self.path.iterdir() if p.suffix.lower() in _IMAGE_EXTS)
            if not files:
                raise InputError(f"{self.path}: folder holds no image frames")
            self._files = files
            self.n_frames = len(files)
            first = self._read_file(0)
        else:
            self._cap = cv2.VideoCapture(str(self.path))
            if not self._cap.isOpened():
                raise InputError(f"{self.path}: cannot open as a video")
            self.n_frames = int(self._cap.get(cv2.CAP_PROP_FRAME_COUNT) or 0)
            first = self._read_cap(0)
        if first is None:
            raise InputError(f"{self.path}: no frame could be decoded")
        self.size = (int(first.shape[1]), int(first.shape[0]))

    def describe(self) -> dict[str, Any]:
        """JSON-able summary for the page."""
        return {"path": self.path.name, "width": self.size[0], "height": self.size[1],
                "n_frames": self.n_frames}  # fmt: skip

    def _read_file(self, k: int) -> np.ndarray | None:
        assert self._files is not None
        if not 0 <= k < len(self._files):
            return None
        return self._cv2.imread(str(self._files[k]), self._cv2.IMREAD_COLOR)

    def _read_cap(self, k: int) -> np.ndarray | None:
        cv2 = self._cv2
        if k != self._next:
            self._cap.set(cv2.CAP_PROP_POS_FRAMES, k)
        ok, frame = self._cap.read()
        self._next = k + 1 if ok else -1
        return frame if ok else None

    def jpeg(self, k: int, quality: int = 85) -> bytes:
        """Frame ``k`` (0-based) as JPEG bytes; :class:`InputError` past the end."""
        cv2 = self._cv2
        with self._lock:
            bgr = self._read_file(k) if self._files is not None else self._read_cap(k)
        if bgr is None:
            raise InputError(f"{self.path}: frame {k} cannot be decoded (past the end?)")
        h, w = bgr.shape[:2]
        if w > _MAX_WIDTH:
            bgr = cv2.resize(bgr, (_MAX_WIDTH, int(round(h * _MAX_WIDTH / w))),
                             interpolation=cv2.INTER_AREA)  # fmt: skip
        ok, buf = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
        if not ok:
            raise InputError(f"{self.path}: frame {k} could not be encoded")
        return buf.tobytes()

    def close(self) -> None:
        if self._cap is not None:
            self._cap.release()
