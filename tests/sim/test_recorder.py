"""The committed-frames marker: every version of ``zarr.json`` a kill could leave is consistent."""

from __future__ import annotations

import json

import numpy as np
import zarr.storage

from thermoswarm.sim.recorder import ZarrRecorder, load_checkpoint


def test_each_metadata_write_keeps_marker_and_checkpoint_together(tmp_path, monkeypatch):
    seen: list[dict] = []
    original = zarr.storage.LocalStore.set

    async def spy(self, key, value):
        await original(self, key, value)
        if key == "zarr.json":  # the group's metadata, as a kill at this moment would leave it
            attrs = json.loads(value.to_bytes())["attributes"]
            ck = attrs.get("checkpoint_file")
            frame = int(load_checkpoint(tmp_path / ck)["frame"]) if ck else None
            seen.append({**attrs, "checkpoint_frame": frame})

    monkeypatch.setattr(zarr.storage.LocalStore, "set", spy)
    n, block = 5, 4
    rec = ZarrRecorder(tmp_path / "tracks.zarr", n=n, n_frames=12, block=block)
    seen.clear()
    pos = np.zeros((n, 2))
    for frame in range(12):
        if rec.add(float(frame), pos + frame, {}):
            rec.flush({"frame": np.array(frame)}, step=frame)
    assert len(seen) == 3  # one metadata write per committed block, not one per key
    for attrs in seen:
        assert attrs["committed_frames"] == attrs["checkpoint_frame"] + 1
        assert attrs["checkpoint_step"] == attrs["checkpoint_frame"]
