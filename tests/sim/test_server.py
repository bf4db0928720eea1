"""The simulator's I/O shell: the autopilot's working directory (MAVLink FTP root, scripts/)."""

from __future__ import annotations

from pathlib import Path

from helixd.mav.guard_script import script_bytes
from helixd.sim.server import SimServer, prepare_workdir, read_scripts
from helixd.sim.sim_config import SimConfig


def test_a_temporary_workdir_is_made_and_removed() -> None:
    server = SimServer(["udpin:127.0.0.1:0"], SimConfig(noise="none", guard_installed=True))
    workdir = server.workdir
    assert (workdir / "scripts" / "helixd-guard.lua").read_bytes() == script_bytes()
    server.start()
    try:
        snap = server.wait_for(lambda s: s.guard_version is not None, 20.0)
        assert snap.guard_version == 1 and snap.params["SCR_ENABLE"] == 1.0
    finally:
        server.stop()
    assert not workdir.exists()


def test_a_given_workdir_is_kept_and_its_scripts_read(tmp_path: Path) -> None:
    workdir = tmp_path / "ap"
    got = prepare_workdir(SimConfig(workdir=workdir))
    assert got == workdir.resolve() and got.is_dir()
    assert read_scripts(got) == {}  # no scripts/ yet
    (got / "scripts").mkdir()
    (got / "scripts" / "a.lua").write_bytes(b"a")
    (got / "scripts" / "notes.txt").write_bytes(b"n")
    (got / "scripts" / "dir.lua").mkdir()
    assert read_scripts(got) == {"a.lua": b"a"}
    server = SimServer(["udpin:127.0.0.1:0"], SimConfig(workdir=workdir))
    server.start()
    server.stop()
    assert (got / "scripts" / "a.lua").exists()  # not the simulator's to remove
