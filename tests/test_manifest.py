"""The manifest of what an output directory holds (pcsg/resume.py)."""
from pcsg import resume
from pcsg.resume import Manifest


def test_records_are_saved_at_most_every_second_and_all_at_the_flush(tmp_path, monkeypatch):
    # the whole file was written after every frame: 137 ms a frame at 20,000 entries
    writes = []
    real = resume.write_atomic
    monkeypatch.setattr(resume, "write_atomic", lambda p, b: (writes.append(p), real(p, b)))
    monkeypatch.setattr(resume, "SAVE_EVERY", 1e9)     # however slow this machine is
    m = Manifest(tmp_path)
    for k in range(200):
        png = tmp_path / f"f{k}.png"
        png.write_bytes(b"x%d" % k)
        m.record(png, f"key{k}")
    assert writes == []
    m.flush()
    back = Manifest(tmp_path)
    assert len(back.entries) == 200 and back.entries["f7.png"]["key"] == "key7"
    m.flush()                           # nothing new: nothing written
    assert len(writes) == 1


def test_a_record_after_a_second_saves_at_once(tmp_path, monkeypatch):
    m = Manifest(tmp_path)
    monkeypatch.setattr(resume, "SAVE_EVERY", 0.0)
    (tmp_path / "a.png").write_bytes(b"a")
    m.record(tmp_path / "a.png", "k")
    assert "a.png" in Manifest(tmp_path).entries


def test_a_long_legal_name_is_written_atomically(tmp_path):
    """The temporary file beside it took the name with 15 characters more: a name of 241
    to 255 bytes failed with "File name too long", naming the temporary file."""
    from pcsg.output import write_atomic
    for length in (240, 250, 255):
        target = tmp_path / ("b" * (length - 4) + ".png")
        write_atomic(target, b"picture")
        assert target.read_bytes() == b"picture"
        write_atomic(target, b"again")          # over the earlier one
        assert target.read_bytes() == b"again"
    assert sorted(len(p.name) for p in tmp_path.iterdir()) == [240, 250, 255]


def test_a_frame_of_another_pcsg_is_rendered_again(tmp_path, monkeypatch):
    """The key held pcsg's version number, which no change moves: frames an older pcsg
    rendered were reused. It holds a hash of pcsg's sources, every module's."""
    import shutil
    from pathlib import Path
    from pcsg.render.job import Options
    here = Path(resume.__file__).resolve().parent
    copy = tmp_path / "pcsg"
    shutil.copytree(here, copy, ignore=shutil.ignore_patterns("__pycache__"))
    digest = resume.code_digest.__wrapped__
    before = digest(copy)
    assert before == resume.code_digest() == digest(here)
    shade = copy / "render" / "shade.py"
    shade.write_text(shade.read_text() + "\n# another version\n")
    assert digest(copy) != before
    shade.unlink()
    assert digest(copy) != before
    # and the key of a frame follows it
    key = resume.output_key("sphere\n", Options())
    monkeypatch.setattr(resume, "code_digest", lambda: "another pcsg")
    assert resume.output_key("sphere\n", Options()) != key


def test_two_runs_into_one_directory_keep_each_others_records(tmp_path):
    """Each run wrote the entries it had read at its start with its own: of two sweeps
    into one directory the last to save dropped the other's, whose images were then
    rendered again (QA: 5 of 10 entries left, 3 times of 3)."""
    first, second = Manifest(tmp_path), Manifest(tmp_path)
    for m, names in ((first, "abc"), (second, "xyz")):
        for n in names:
            (tmp_path / f"{n}.png").write_bytes(n.encode())
            m.record(tmp_path / f"{n}.png", f"key-{n}")
    first.flush()
    second.flush()
    assert sorted(Manifest(tmp_path).entries) == [f"{n}.png" for n in "abcxyz"]
    # what one drops (a shorter animation's frames) goes, the other's stays
    assert first.forget_others({"a.png", "x.png"}, mine=lambda n: n in ("b.png", "c.png")) \
        == ["b.png", "c.png"]
    second.record(tmp_path / "z.png", "key-z2")
    second.flush()
    back = Manifest(tmp_path).entries
    assert sorted(back) == ["a.png", "x.png", "y.png", "z.png"]
    assert back["z.png"]["key"] == "key-z2" and back["a.png"]["key"] == "key-a"
