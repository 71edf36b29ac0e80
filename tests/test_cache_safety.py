"""The on-disk cache holds data, never code jaxroll runs when it reads it (issue 37, item 7): stored programs and
moment tables are `.npz` entries read without pickle, verified (digest, key, versions, owner), anything else a miss;
a cache folder that others can write to is refused."""

import json
import os
import pickle
import stat

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxroll
from jaxroll import _cache_files as files, _compiled


class _Marker:
    """A pickle that, when loaded, runs a shell command that writes a marker file (the issue's payload)."""

    def __init__(self, path):
        self.path = str(path)

    def __reduce__(self):
        return (os.system, (f"echo executed > {self.path}",))


@pytest.fixture
def store(tmp_path, monkeypatch):
    """jaxroll's stores (programs, moment tables) in a folder of their own, nothing loaded in memory."""
    from jaxroll.theory import _moment_cache

    folder = tmp_path / "cache"
    folder.mkdir(mode=0o700)
    monkeypatch.setattr(_compiled, "cache_dir", lambda: folder / "jaxroll-programs")
    monkeypatch.setattr(_moment_cache, "cache_dir", lambda: folder / "jaxroll-moment")
    monkeypatch.setattr(_compiled, "_LOADED", {})
    _moment_cache.cached_tables.cache_clear()
    yield folder
    _moment_cache.cached_tables.cache_clear()


class _Params(eqx.Module):
    scale: jax.Array
    label: str = eqx.field(static=True)


@_compiled.cached_program
def _program(params: _Params, x, power: int):
    return {"y": params.scale * x**power, "label": params.label, "n": power, "status": jnp.sum(x) > 0}


def _tables_args():
    """The moment tables' arguments for the roll of the default ship under the order-4 filter (closure order 4)."""
    from jaxroll.theory import _moment_equations as me

    ship = jaxroll.c11_representative()
    wave = jaxroll.EffectiveWave(jaxroll.ITTC(7.0, 10.0), ship.lpp)
    sde = jaxroll.theory.roll_sde(
        ship, jaxroll.fit_filter(wave, order=4, match_frequency=2 * ship.omega0).filter
    )
    return sde._structure(), 4, me._extra_monomials(sde.dim, sde.symmetric)


def test_a_planted_pickle_is_never_run_and_is_a_miss(store, tmp_path):
    """The issue's attack: with JAXROLL_CACHE_DIR a folder someone else can write to, a pickle planted as a stored
    program (`jaxroll-programs/*.bin`) or as moment tables (`jaxroll-moment/tables-*.pkl`) ran arbitrary code when
    read. Planted under every name jaxroll reads (old and new), it is not run (no marker), the entry is a miss, and
    the program's and the tables' results are those of a fresh computation."""
    from jaxroll.theory import _moment_cache, _moment_equations as me

    marker = tmp_path / "marker"
    params, x = _Params(jnp.asarray(2.0), "a"), jnp.linspace(0.0, 1.0, 5)
    first = _program(params, x, 3)
    args = _tables_args()
    fresh_tables = _moment_cache.cached_tables(*args)
    entries = sorted(store.rglob("*.npz"))
    assert {p.parent.name for p in entries} == {"jaxroll-moment", "jaxroll-programs"}
    payload = pickle.dumps(_Marker(marker))
    for path in entries:
        path.write_bytes(payload)
        path.with_suffix(".bin").write_bytes(payload)  # the names of jaxroll < 0.2
        path.with_suffix(".pkl").write_bytes(payload)
    assert all(files.read_entry(p, p.stem.removeprefix("tables-")) is None for p in entries)  # a miss
    _compiled._LOADED.clear()
    _moment_cache.cached_tables.cache_clear()
    again = _program(params, x, 3)
    args = _tables_args()  # (the filter fit's programs, read again too)
    tables = _moment_cache.cached_tables(*args)
    assert not marker.exists()  # nothing was executed
    np.testing.assert_array_equal(again["y"], first["y"])
    assert again["label"] == "a" and again["n"] == 3 and bool(again["status"])
    assert tables.monomials == fresh_tables.monomials and tables.index == fresh_tables.index
    assert tables.key == me._build_tables.__wrapped__(*args).key
    for path in entries:  # exported and generated again, and stored in their place as data
        assert files.read_entry(path, path.stem.removeprefix("tables-")) is not None
    assert not marker.exists()


def test_stored_programs_and_tables_come_back_the_same(store):
    """Read back from their entries (a new process: nothing in memory), a program gives the same bits and the same
    static outputs, and the moment tables equal freshly generated ones; a `MomentEquations` in a stored output is
    kept by its tables' key and comes back holding the tables of the tables cache (the same object)."""
    from jaxroll.theory import _moment_cache, _moment_equations as me

    params, x = _Params(jnp.asarray(1.5), "b"), jnp.linspace(-1.0, 1.0, 7)
    first = _program(params, x, 2)
    _compiled._LOADED.clear()
    second = _program(params, x, 2)
    np.testing.assert_array_equal(second["y"], first["y"])
    np.testing.assert_allclose(second["y"], 1.5 * np.linspace(-1.0, 1.0, 7) ** 2, rtol=1e-15, atol=1e-15)
    assert (second["label"], second["n"]) == ("b", 2)
    args = _tables_args()
    written = _moment_cache.cached_tables(*args)
    _moment_cache.cached_tables.cache_clear()
    read = _moment_cache.cached_tables(*args)
    assert read is not written and read.monomials == written.monomials and read.index == written.index
    for a, b in zip(jax.tree.leaves(read.arrays), jax.tree.leaves(written.arrays), strict=True):
        np.testing.assert_array_equal(a, b)
        assert a.dtype == b.dtype
    equations = me.MomentEquations(read)
    text, arrays = files.encode({"equations": equations})
    assert len(text) + sum(a.nbytes for a in arrays.values()) < 5_000  # the key, not megabytes of tables
    assert files.decode(text, arrays)["equations"].tables is read


def test_corrupt_truncated_foreign_or_exposed_entries_are_misses(store):
    """A truncated file, a changed byte, an entry of another key or of other versions, a file of another user or
    writable by others: each is a miss (no message, no traceback), and the program runs with the right numbers."""
    params, x = _Params(jnp.asarray(3.0), "c"), jnp.arange(4.0)
    ref = np.asarray(_program(params, x, 1)["y"])
    (path,) = (store / "jaxroll-programs").glob("*.npz")
    key, good = path.stem, path.read_bytes()
    assert files.read_entry(path, key) is not None

    def changed_member(data: bytes) -> bytes:
        """The same archive, one byte of the exported program changed (its zip checksums recomputed)."""
        import io

        with np.load(io.BytesIO(data), allow_pickle=False) as npz:
            members = {name: npz[name].copy() for name in npz.files}
        members["exported"][len(members["exported"]) // 2] ^= 0xFF
        buf = io.BytesIO()
        np.savez(buf, **members)
        return buf.getvalue()

    def other_versions(data: bytes) -> bytes:
        import io

        with np.load(io.BytesIO(data), allow_pickle=False) as npz:
            members = {name: npz[name] for name in npz.files}
        meta = json.loads(files.member_text(members["__meta__"]))
        meta["versions"]["jax"] = "0.0.1"
        members["__meta__"] = files.text_member(json.dumps(meta))
        buf = io.BytesIO()
        np.savez(buf, **members)
        return buf.getvalue()

    def write(data: bytes, mode=0o600, owner=None):
        path.unlink(missing_ok=True)
        path.write_bytes(data)
        path.chmod(mode)
        if owner is not None:
            os.chown(path, owner, -1)

    cases = {
        "truncated": lambda: write(good[: len(good) // 2]),
        "empty": lambda: write(b""),
        "a changed byte": lambda: write(changed_member(good)),
        "other versions": lambda: write(other_versions(good)),
        "writable by others": lambda: write(good, 0o666),
        "writable by its group": lambda: write(good, 0o620),
    }
    if os.geteuid() == 0:
        cases["another user's"] = lambda: write(good, owner=12345)
    assert files.read_entry(path, "0" * 32) is None  # another key's entry
    for name, damage in cases.items():
        damage()
        assert files.read_entry(path, key) is None, name
        _compiled._LOADED.clear()
        np.testing.assert_array_equal(_program(params, x, 1)["y"], ref, err_msg=name)
        assert files.read_entry(path, key) is not None, name  # stored again, as data


def test_decode_builds_only_data_and_known_classes():
    """`decode` rebuilds numbers, strings, containers, arrays and the Modules/dataclasses of jaxroll and the libraries
    it builds on — never a function, a class of another package, or a class from a module not yet imported, and
    never an array of Python objects."""
    sea = jax.tree.map(np.asarray, jaxroll.ITTC(7.0, 10.0))  # a Module of jaxroll, NumPy leaves
    static = {
        "label": "x",
        "n": 3,
        "t": (1, 2.5, None, True),
        "a": np.arange(3.0),
        "sea": sea,
        "again": sea,
        "f": np.float32(0.25),
        "inf": float("inf"),
    }
    text, arrays = files.encode(static)
    back = files.decode(text, arrays)
    assert back["label"] == "x" and back["t"] == (1, 2.5, None, True) and back["inf"] == float("inf")
    assert type(back["sea"]) is jaxroll.ITTC and back["again"] is back["sea"]  # shared stays shared
    assert float(back["sea"].hs) == 7.0 and back["f"] == np.float32(0.25) and back["f"].dtype == np.float32
    np.testing.assert_array_equal(back["a"], np.arange(3.0))
    with pytest.raises(files.Unencodable):  # a class outside jaxroll and its libraries (this test module's)
        files.encode(_Params(np.asarray(1.0), "p"))
    for name in (
        "os:system",
        "builtins:eval",
        "subprocess:Popen",
        "pickle:loads",
        "jaxroll._compiled:write_atomic",
        "jaxroll.notamodule:Thing",
        "tests.test_cache_safety:_Marker",
    ):
        for tag in ("o", "c", "k"):
            node = (
                {"o": name, "id": 0, "f": []}
                if tag == "o"
                else {"k": name, "v": 1}
                if tag == "k"
                else {tag: name}
            )
            with pytest.raises((ValueError, KeyError, AttributeError, TypeError)):
                files.decode(json.dumps(node), {})
    with pytest.raises(files.Unencodable):
        files.encode({"f": print})
    with pytest.raises(files.Unencodable):
        files.encode(np.array([object()]))
    with pytest.raises(files.Unencodable):
        files.encode(_Marker("x"))
    import io

    buf = io.BytesIO()
    np.save(buf, np.array([_Marker("x")], dtype=object), allow_pickle=True)
    with pytest.raises(ValueError):  # an object array in an entry is refused by NumPy before anything runs
        np.load(io.BytesIO(buf.getvalue()), allow_pickle=False)


def test_a_cache_folder_others_can_write_is_refused(tmp_path, monkeypatch):
    """`enable_compilation_cache` (what the `jaxroll` command calls) refuses a folder that others can write to — JAX
    would load the compiled code it finds there — with a warning that says why and how to fix it, and leaves JAX's
    cache as it was; jaxroll keeps nothing in such a folder when JAX's cache points there anyway. The folder's
    owner counts too, and every folder above it, except one with the sticky bit (/tmp)."""
    before = jax.config.jax_compilation_cache_dir
    shared = tmp_path / "shared"
    shared.mkdir()
    shared.chmod(0o777)
    files.unsafe_reason.cache_clear()
    try:
        with pytest.warns(
            UserWarning,
            match=r"the compilation cache .* is not used: .*shared is writable by every "
            r"user \(mode 777\), so others could plant compiled code there",
        ):
            assert jaxroll.enable_compilation_cache(shared) is None
        assert jax.config.jax_compilation_cache_dir == before
        group = tmp_path / "group"
        group.mkdir(mode=0o770)
        group.chmod(0o770)
        assert "writable by its group" in files.unsafe_reason(str(group))
        below = tmp_path / "shared-parent"
        below.mkdir()
        below.chmod(0o777)  # the folder is the user's, but anyone can rename it and put another in its place
        assert "shared-parent is writable by every user" in files.unsafe_reason(str(below / "xla"))
        sticky = tmp_path / "tmp-like"
        sticky.mkdir()
        sticky.chmod(0o1777)  # like /tmp: others cannot move what is the user's
        assert files.unsafe_reason(str(sticky / "xla")) is None
        assert stat.S_IMODE((sticky / "xla").stat().st_mode) == 0o700  # created by jaxroll, for the user only
        if os.geteuid() == 0:  # owned by another user
            theirs = tmp_path / "theirs"
            theirs.mkdir(mode=0o700)
            os.chown(theirs, 12345, -1)
            assert "belongs to another user (uid 12345)" in files.unsafe_reason(str(theirs))
        # JAX's cache set to such a folder directly: jaxroll keeps no programs or tables there
        monkeypatch.setattr(_compiled, "_REFUSED", set())
        jax.config.update("jax_compilation_cache_dir", str(shared))
        with pytest.warns(UserWarning, match="jaxroll keeps no programs or tables in"):
            assert _compiled.cache_dir() is None
        from jaxroll.theory import _moment_cache

        assert _moment_cache.cache_dir() is None  # (said once)
        ours = tmp_path / "ours"
        assert jaxroll.enable_compilation_cache(ours) == ours
        assert _compiled.cache_dir() == ours / "jaxroll-programs"
    finally:
        jax.config.update("jax_compilation_cache_dir", before)
        files.unsafe_reason.cache_clear()


def _returns_within(seconds, call):
    """`call()`'s result, or a failure where it has not returned within `seconds` (a FIFO hangs an `open`)."""
    import threading

    box = {}

    def run():
        try:
            box["out"] = call()
        except Exception as e:  # re-raised in the test's thread
            box["error"] = e

    t = threading.Thread(target=run, daemon=True)
    t.start()
    t.join(seconds)
    assert not t.is_alive(), f"{call} did not return within {seconds} s (a FIFO read as a file?)"
    if "error" in box:
        raise box["error"]
    return box["out"]


def test_a_fifo_in_place_of_an_entry_or_a_checkpoint_is_a_miss_not_a_hang(store, tmp_path):
    """Issue 45 item 7: a FIFO planted as a program-cache entry or a Monte Carlo checkpoint hung the command (killed
    after 120 s): only regular files are read."""
    from jaxroll.roll._sharding import _load_checkpoint

    params, x = _Params(jnp.asarray(3.0), "fifo"), jnp.arange(4.0)
    ref = np.asarray(_program(params, x, 1)["y"])
    (path,) = (store / "jaxroll-programs").glob("*.npz")
    path.unlink()
    os.mkfifo(path, 0o600)
    assert _returns_within(10, lambda: files.read_entry(path, path.stem)) is None
    _compiled._LOADED.clear()
    np.testing.assert_array_equal(_returns_within(30, lambda: _program(params, x, 1)["y"]), ref)
    assert path.is_file() and files.read_entry(path, path.stem) is not None  # stored again over the FIFO
    fifo = tmp_path / "checkpoint.npz"
    os.mkfifo(fifo)
    with pytest.raises(ValueError, match=r"checkpoint .*checkpoint\.npz is not a regular file \(a FIFO"):
        _returns_within(10, lambda: _load_checkpoint(fifo, {}))


def test_another_program_under_a_valid_digest_is_a_miss(store):
    """Issue 45 item 12: an entry whose digest was recomputed over another program (other arguments) ended the
    command in exit 2 with JAX's "args is a tuple of length … when exported"; it is a miss, exported again."""

    @_compiled.cached_program
    def three(a, b, c):
        return a + b + c

    params, x = _Params(jnp.asarray(3.0), "swap"), jnp.arange(4.0)
    ref = np.asarray(_program(params, x, 1)["y"])
    three(jnp.asarray(1.0), jnp.asarray(2.0), jnp.arange(3.0))
    entries = sorted((store / "jaxroll-programs").glob("*.npz"), key=lambda p: p.stat().st_mtime_ns)
    mine, theirs = entries
    mine.write_bytes(files.entry_bytes(mine.stem, files.read_entry(theirs, theirs.stem)))
    mine.chmod(0o600)
    assert files.read_entry(mine, mine.stem) is not None  # a valid entry, of another program
    _compiled._LOADED.clear()
    np.testing.assert_array_equal(_program(params, x, 1)["y"], ref)


def test_a_cache_path_that_cannot_be_used_warns_with_the_real_reason(tmp_path, monkeypatch):
    """Issue 45 item 12: a cache path that is a file (or on a read-only file system) warned "…, so others could
    plant compiled code there"; the warning now gives the reason from the operating system."""
    import errno
    import tempfile

    before = jax.config.jax_compilation_cache_dir
    afile = tmp_path / "afile"
    afile.write_text("")
    files.unusable_reason.cache_clear()
    try:
        with pytest.warns(
            UserWarning, match=r"is not used: .*afile is a file, not a folder\. Every program"
        ) as w:
            assert jaxroll.enable_compilation_cache(afile) is None
        assert "others could plant" not in str(w[0].message)
        with pytest.warns(UserWarning, match=r"a file stands where a folder above .*afile/xla should be"):
            assert jaxroll.enable_compilation_cache(afile / "xla") is None

        def read_only(*args, **kwargs):
            raise OSError(errno.EROFS, "Read-only file system")

        monkeypatch.setattr(tempfile, "mkstemp", read_only)
        with pytest.warns(
            UserWarning, match=r"no file can be written in it \(it is on a read-only file system\)"
        ):
            assert jaxroll.enable_compilation_cache(tmp_path / "ro") is None
        assert jax.config.jax_compilation_cache_dir == before
    finally:
        files.unusable_reason.cache_clear()
