"""A mesh script is screened before Gmsh reads it (issue 21, item 1; fenics_plast/geo_screen.py).

Each command of Gmsh 4.8's script language that runs a program or touches a file is refused with
its file, line and command; comments and strings do not fool the screen either way; Include and
Merge are followed (and kept to the scene's folder and meshes/); the files Gmsh reads besides the
script itself (``<file>.opt``, a ``.msh`` that is really a script) are screened too; every shipped
``.geo`` passes. Through the CLI: ``--set mesh.file=evil.geo`` with a ``SystemCall`` exits 2 naming
``mesh.file`` and runs nothing; ``--trust-mesh-script`` lets it run.

Issue 34, item 1: suffixes in every case (``evil.GEO``, ``tool.Msh``, ``Merge "x.gEo"``, the ``.opt``
beside each) are screened as what Gmsh takes them for, and only the exact data suffixes pass a Merge;
a linked mesh file or tool file (to a file, a chain of links, through a linked folder) is resolved,
screened and handed to Gmsh by its resolved name (the ``.opt`` beside both names screened), a dangling
link or a loop is not found; a script that names a link (Include, Merge, ShapeFromFile, ListFromFile)
or a ``.opt`` that is one is refused. Each tester's file through ``fenics-plast run``: exit 2, nothing
run, nothing written. tests/test_screen_fuzz.py fuzzes the same with Hypothesis.
"""
from __future__ import annotations

import itertools
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from fenics_plast.geo_screen import DATA_SUFFIXES, GeoScreenError, input_files, mesh_file_kind, scan, screen

ROOT = Path(__file__).resolve().parent.parent
GEO = ROOT / "meshes" / "round_bar.geo"
BAR = ROOT / "tests" / "scenes" / "bar.toml"

# (line of .geo, command named in the refusal)
REFUSED = [
    ('SystemCall "touch pwned";', "SystemCall"),
    ("System 'touch pwned';", "System"),
    ('NonBlockingSystemCall "touch pwned";', "NonBlockingSystemCall"),
    ('cmd = "touch pwned"; SystemCall cmd;', "SystemCall"),
    ('SystemCall StrCat("touch ", "pwned");', "SystemCall"),
    ('Shell "touch pwned";', "Shell"),
    ('OnelabRun "client";', "OnelabRun"),
    ('OnelabRun("client", "touch pwned");', "OnelabRun"),
    ('Printf("x") > "pwned";', "Printf(...) >"),
    ('Printf("%g", 1) >> "pwned";', "Printf(...) >>"),
    ('Printf("x") > StrCat("pw", "ned");', "Printf(...) >"),
    ('Save "pwned.msh";', "Save"),
    ('Save View[0] "pwned.pos";', "Save"),
    ('Print "pwned.png";', "Print"),
    ('CreateDir "pwned";', "CreateDir"),
    ('Delete File "pwned";', "Delete File"),
    ('DeleteFile "pwned";', "DeleteFile"),
    ('SendToServer View[0] "x";', "SendToServer"),
    ("Plugin(Crack).Run;", "Plugin"),
    ("Exit;", "Exit"),
    ('S2N["SystemCall"] "touch pwned";', "SystemCall"),
    ('StringToName["Save"] "pwned";', "Save"),
    ('S2N[StrCat("System", "Call")] "touch pwned";', "S2N"),
    ('Include "/etc/hostname";', 'Include "/etc/hostname"'),
    ('Include StrCat(CurrentDir, "x.geo");', "Include"),
    ('Include "missing.geo";', 'Include "missing.geo"'),
    ('Merge "data.txt";', 'Merge "data.txt"'),
    ('Merge "data.msh.gz";', 'Merge "data.msh.gz"'),
    ('Merge "solver.py";', 'Merge "solver.py"'),
    ('Merge "shape.Stl";', 'Merge "shape.Stl"'),
    ('MergeWithBoundingBox "data.txt";', 'MergeWithBoundingBox "data.txt"'),
    ('Merge "script.msh";', "mesh file"),
    ('x() = ListFromFile("/etc/hostname");', 'ListFromFile "/etc/hostname"'),
    ('/* unterminated', "text"),
]


def _geo(folder: Path, line: str, name: str = "evil.geo") -> Path:
    """The bar's .geo with ``line`` as its line 3, and the files it may name beside it."""
    folder.mkdir(parents=True, exist_ok=True)
    for n in ("data.txt", "data.msh.gz", "solver.py", "shape.Stl"):
        (folder / n).write_text("x")
    (folder / "script.msh").write_text('SystemCall "touch pwned";\n')        # a "mesh" that is a script
    text = GEO.read_text().splitlines()
    path = folder / name
    path.write_text("\n".join(text[:2] + [line] + text[2:]) + "\n")
    return path


@pytest.mark.parametrize("line, command", REFUSED, ids=[c for _, c in REFUSED])
def test_refused(tmp_path, line, command):
    path = _geo(tmp_path, line)
    with pytest.raises(GeoScreenError) as e:
        screen(path)
    msg = str(e.value)
    finding = scan(path).findings[0]
    assert finding.command == command, finding
    where = finding.file
    assert f"{where}, line {finding.line}: {command} " in msg and "--trust-mesh-script" in msg
    if where == path:
        assert finding.line == 3


@pytest.mark.parametrize("line", [
    '// SystemCall "touch pwned";',
    '/* Save "x";\n Exit; */',
    'Printf("SystemCall \'touch pwned\' and Exit;");',
    "s = 'Save \"x.msh\"; Plugin(Crack).Run;';",
    'Printf("r = %g", 1.0);',
    "Save = 3; Shell = Save + 1; Print[] = {1, 2}; x = Print[1];",
    "Sleep 0;",
    'Include "ok.geo";',
    'Include "sub/ok.geo";',
    'Merge "real.msh";',
    'Merge "ok.geo";',
    'x() = ListFromFile("numbers.txt");',
    'S2N["radius2"] = 3;',
    "SystemCallX = 1; MySave = 2;",
])
def test_allowed(tmp_path, line):
    (tmp_path / "sub").mkdir()
    (tmp_path / "ok.geo").write_text("p = 1;\n")
    (tmp_path / "sub" / "ok.geo").write_text("// a harmless include\nq = 2;\n")
    (tmp_path / "real.msh").write_text("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n")
    (tmp_path / "numbers.txt").write_text("1 2 3\n")
    path = _geo(tmp_path, line)
    assert scan(path).findings == []
    assert screen(path)[0] == path.resolve()


def test_includes_are_screened_recursively_and_listed(tmp_path):
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "deeper.geo").write_text('x = 1;\n\n\nSave "pwned.msh";\n')
    (tmp_path / "sub" / "part.geo").write_text('Include "deeper.geo";\n')   # relative to sub/, as Gmsh does
    path = _geo(tmp_path, 'Include "sub/part.geo";')
    with pytest.raises(GeoScreenError, match=r"deeper\.geo, line 4: Save writes a file"):
        screen(path)
    assert input_files(path) == [path.resolve(), (tmp_path / "sub" / "part.geo").resolve(),
                                 (tmp_path / "sub" / "deeper.geo").resolve()]
    # an Include cycle ends
    (tmp_path / "a.geo").write_text('Include "b.geo";\n')
    (tmp_path / "b.geo").write_text('Include "a.geo";\n')
    assert scan(tmp_path / "a.geo").findings == []


def test_include_outside_the_scene_folder(tmp_path):
    outside = tmp_path / "elsewhere" / "part.geo"
    outside.parent.mkdir()
    outside.write_text("p = 1;\n")
    path = _geo(tmp_path / "scene", 'Include "../elsewhere/part.geo";')
    with pytest.raises(GeoScreenError, match="reads a file outside the scene's folder"):
        screen(path)
    # the scene's folder (above the mesh file's) and the package's meshes/ are allowed
    assert screen(path, scene_dir=tmp_path) == [path.resolve(), outside.resolve()]
    inc = _geo(tmp_path / "x", f'Include "{GEO}";')
    assert GEO.resolve() in screen(inc)


def test_opt_files_gmsh_merges_are_screened(tmp_path):
    path = _geo(tmp_path, "p = 1;")
    Path(str(path) + ".opt").write_text('Mesh.Algorithm = 8;\nSystemCall "touch pwned";\n')
    with pytest.raises(GeoScreenError, match=r"evil\.geo\.opt, line 2: SystemCall runs a program"):
        screen(path)
    msh = tmp_path / "m.msh"
    msh.write_text("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n")
    assert screen(msh) == [msh.resolve()]
    Path(str(msh) + ".opt").write_text('Save "x";\n')
    with pytest.raises(GeoScreenError, match=r"m\.msh\.opt, line 1: Save writes a file"):
        screen(msh)


def test_an_unterminated_string_is_refused(tmp_path):
    path = tmp_path / "x.geo"
    path.write_text('p = 1;\na = "no end;\nSystemCall "ls";\n')      # Gmsh's lexer: the string ends at "ls
    r = scan(path)
    assert [(f.line, f.command) for f in r.findings] == [(3, "text")]
    path.write_text('p = 1;\na = "no end;\n')
    with pytest.raises(GeoScreenError, match=r"x\.geo, line 2: text cannot be screened: a string that never ends"):
        screen(path)


def test_a_msh_file_that_is_a_script_is_refused(tmp_path):
    msh = tmp_path / "m.msh"
    msh.write_text('SystemCall "touch pwned";\n')
    with pytest.raises(GeoScreenError, match="is not a Gmsh mesh"):
        screen(msh)


def _shipped_geo_files():
    found = []
    for folder in ("meshes", "docs", "tests", "demos", "benchmarks", "studies", "scripts"):
        found += sorted((ROOT / folder).rglob("*.geo")) if (ROOT / folder).is_dir() else []
    return found


def test_every_shipped_geo_passes():
    files = _shipped_geo_files()
    assert len(files) >= 10 and (ROOT / "docs" / "tutorial" / "billet.geo") in files
    for f in files:
        assert scan(f).findings == [], f


# ----------------------------------------------------------------------------------------------
# through the CLI


def _run(*args, cwd):
    env = dict(os.environ, FENICS_PLAST_PROGRESS="off")
    p = subprocess.run([sys.executable, "-m", "fenics_plast.cli", *map(str, args)], capture_output=True, text=True,
                       cwd=cwd, env=env, timeout=300)
    return p.returncode, p.stdout, p.stderr


def test_cli_refuses_a_geo_that_runs_a_program(tmp_path):
    pwned = tmp_path / "pwned"
    evil = _geo(tmp_path, f'SystemCall "touch {pwned}";')
    out = tmp_path / "out"
    rc, _, err = _run("run", BAR, "--out", out, "--set", f'mesh.file="{evil}"', cwd=tmp_path)
    assert rc == 2, err
    assert f"mesh.file: {evil}, line 3: SystemCall runs a program" in err and "Traceback" not in err
    assert not pwned.exists() and not out.exists()
    # the user trusts the script: it runs (and so does the command)
    rc, _, err = _run("run", BAR, "--out", out, "--set", f'mesh.file="{evil}"', "--trust-mesh-script", cwd=tmp_path)
    assert rc == 0, err
    assert pwned.exists()


def test_study_passes_the_flag_to_its_runs(tmp_path):
    from fenics_plast import cli
    from fenics_plast.study.execute import run_command
    assert "--trust-mesh-script" in run_command(BAR, [], tmp_path, trust_mesh_script=True)
    assert "--trust-mesh-script" not in run_command(BAR, [], tmp_path)
    assert cli.build_parser().parse_args(["study", str(BAR), "--vary", "mesh.refine=1",
                                          "--trust-mesh-script"]).trust_mesh_script
    pwned = tmp_path / "pwned"
    evil = _geo(tmp_path, f'SystemCall "touch {pwned}";')
    study = ["study", BAR, "--vary", "mesh.refine=1", "--set", f'mesh.file="{evil}"']
    rc, so, err = _run(*study, "--out", tmp_path / "refused", cwd=tmp_path)
    assert rc == 1 and "SystemCall runs a program" in so + err and not pwned.exists(), so + err
    rc, so, err = _run(*study, "--out", tmp_path / "trusted", "--trust-mesh-script", cwd=tmp_path)
    assert rc == 0 and pwned.exists(), so + err


# ----------------------------------------------------------------------------------------------
# issue 34, item 1: suffixes in any case and symbolic links (the screen decides what Gmsh reads)

HEADER = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"


def _cases(word: str) -> list[str]:
    """Every case variant of the suffix ``.word``: .geo .geO .gEo ... .GEO."""
    return ["." + "".join(c) for c in itertools.product(*[(ch.lower(), ch.upper()) for ch in word])]


GEO_CASES, MSH_CASES = _cases("geo"), _cases("msh")
SCRIPT_CASES = GEO_CASES + MSH_CASES            # every suffix the package takes for mesh.file and a tool


def _evil(marker: Path) -> str:
    return f'p = 1;\nSystemCall "touch {marker}";\n'


class _StubGmsh:
    """Stands in for the gmsh module in meshed_tools._read_group: records what it is asked to open."""

    def __init__(self):
        self.opened = []

    def open(self, name):
        self.opened.append(name)
        raise _Opened(name)


class _Opened(Exception):
    pass


def _tool_opens(path: Path, scene_dir: Path):
    """(what Gmsh is handed for the meshed tool file ``path``, or None, the refusal's text)."""
    from fenics_plast.errors import SceneError
    from fenics_plast.meshed_tools import _read_group
    stub = _StubGmsh()
    try:
        _read_group(stub, path, "wall", 2, scene_dir)
    except _Opened:
        pass
    except (GeoScreenError, SceneError) as e:
        return None, str(e)
    assert len(stub.opened) == 1
    return stub.opened[0], ""


def _body_opens(path: Path, scene_dir: Path, monkeypatch):
    """(what Gmsh is handed by mesh_from_file for mesh.file = ``path``, or None, the refusal's text);
    gmsh.open is replaced (it writes the name to a file: Gmsh may run in a child process), so nothing is
    run."""
    from mpi4py import MPI

    from fenics_plast import meshing
    log = scene_dir / "opened.log"
    log.unlink(missing_ok=True)

    def record(name):
        with open(log, "a") as f:
            f.write(f"{name}\n")
        raise _Opened(name)
    monkeypatch.setattr(meshing.gmsh, "open", record)
    try:
        meshing.mesh_from_file(MPI.COMM_SELF, path, scene_dir=scene_dir)
    except meshing.MeshError as e:
        if not log.exists():
            return None, str(e)
    finally:
        monkeypatch.undo()
    opened = log.read_text().splitlines()
    log.unlink()
    assert len(opened) == 1, opened
    return opened[0], ""


@pytest.mark.parametrize("suffix", SCRIPT_CASES)
def test_mesh_file_suffix_in_any_case_is_screened(tmp_path, suffix, monkeypatch):
    """evil.GEO, evil.Msh ...: the kind is the suffix without case, the script is screened, neither the body
    mesh nor a meshed tool hands it to Gmsh; a .msh in any case that is a mesh passes."""
    marker = tmp_path / "pwned"
    evil = tmp_path / f"evil{suffix}"
    evil.write_text(_evil(marker))
    opened, kind = mesh_file_kind(evil)
    assert opened == evil.resolve() and kind == suffix.lower()
    finding = scan(evil).findings[0]
    assert finding.file == evil.resolve()
    assert finding.command == ("SystemCall" if kind == ".geo" else "mesh file")
    assert _body_opens(evil, tmp_path, monkeypatch)[0] is None
    handed, why = _tool_opens(evil, tmp_path)
    assert handed is None and str(evil) in why
    if kind == ".msh":
        evil.write_text(HEADER)
        assert screen(evil) == [evil.resolve()]
        assert _tool_opens(evil, tmp_path)[0] == str(evil.resolve())
    assert not marker.exists()


@pytest.mark.parametrize("suffix", SCRIPT_CASES)
@pytest.mark.parametrize("command", ["Include", "Merge", "MergeWithBoundingBox"])
def test_include_and_merge_suffix_in_any_case(tmp_path, command, suffix):
    """Include and Merge of x.GEO, x.Msh ...: the file is screened as the script Gmsh would read (a .msh in
    any case must start with a mesh header)."""
    (tmp_path / f"x{suffix}").write_text(_evil(tmp_path / "pwned"))
    path = _geo(tmp_path, f'{command} "x{suffix}";')
    findings = scan(path).findings
    script = command == "Include" or suffix.lower() == ".geo"
    assert [(f.file.name, f.command) for f in findings] == [(f"x{suffix}", "SystemCall" if script else "mesh file")]
    if not script:
        (tmp_path / f"x{suffix}").write_text(HEADER)
        assert scan(path).findings == []


@pytest.mark.parametrize("suffix", _cases("stl") + _cases("step") + _cases("stp") + _cases("iges") + _cases("brep")
                         + _cases("brp") + [".txt", ".gz", ".py", ".opt", ""])
def test_merge_takes_only_the_exact_data_suffixes(tmp_path, suffix):
    """Gmsh reads .stl, .STL, .step, .STEP ... as data by the exact suffix; .Stl, .sTEP, .Brep (and any
    other suffix) as a script: Merge takes the exact ones only."""
    (tmp_path / f"x{suffix}").write_text(_evil(tmp_path / "pwned"))
    path = _geo(tmp_path, f'Merge "x{suffix}";')
    findings = scan(path).findings
    if suffix in DATA_SUFFIXES:
        assert findings == []
    else:
        assert [f.command for f in findings] == [f'Merge "x{suffix}"'], findings


@pytest.mark.parametrize("suffix", SCRIPT_CASES)
def test_opt_beside_any_case_is_screened(tmp_path, suffix, monkeypatch):
    """m.GEO.opt, m.Msh.opt, a Merge target's .opt and the .opt of a .opt: Gmsh reads them all as scripts."""
    body = "p = 1;\n" if suffix.lower() == ".geo" else HEADER
    mesh = tmp_path / f"m{suffix}"
    mesh.write_text(body)
    assert scan(mesh).findings == []
    opt = Path(f"{mesh}.opt")
    opt.write_text(_evil(tmp_path / "pwned"))
    assert [(f.file.name, f.command) for f in scan(mesh).findings] == [(opt.name, "SystemCall")]
    assert _body_opens(mesh, tmp_path, monkeypatch)[0] is None and _tool_opens(mesh, tmp_path)[0] is None
    opt.write_text("Mesh.Algorithm = 8;\n")
    Path(f"{opt}.opt").write_text(_evil(tmp_path / "pwned"))                  # Gmsh merges m.geo.opt.opt too
    assert [f.file.name for f in scan(mesh).findings] == [f"{opt.name}.opt"]
    top = _geo(tmp_path, f'Merge "m{suffix}";')
    assert [f.file.name for f in scan(top).findings] == [f"{opt.name}.opt"]


# symbolic links -----------------------------------------------------------------------------------

def _link_to(tmp_path: Path, how: str, target: Path, name: str) -> Path:
    """``tmp_path/name`` made to reach ``target`` in the way ``how``: "file" (a link), "chain" (a link to
    a link), "dangling" (a link to nothing), "loop" (two links to each other), "folder" (a linked folder
    in the middle: the name is lnk/<target's name>)."""
    link = tmp_path / name
    if how == "file":
        link.symlink_to(target)
    elif how == "chain":
        middle = tmp_path / f"middle_{name}"
        middle.symlink_to(target)
        link.symlink_to(middle)
    elif how == "dangling":
        link.symlink_to(tmp_path / f"nothing_{name}")
    elif how == "loop":
        other = tmp_path / f"loop_{name}"
        other.symlink_to(link)
        link.symlink_to(other)
    elif how == "folder":
        lnk = tmp_path / "lnk"
        if not lnk.exists():
            lnk.symlink_to(target.parent, target_is_directory=True)
        link = lnk / target.name
    return link


LINKS = ["file", "chain", "dangling", "loop", "folder"]


@pytest.mark.parametrize("how", LINKS)
@pytest.mark.parametrize("target_name", ["real.geo", "real.GEO", "real.txt", "real.stl", "real.msh", "real.Msh"])
def test_a_linked_mesh_file_is_resolved(tmp_path, how, target_name, monkeypatch):
    """mesh.file and a meshed tool's file may be links (to a file, a link, through a linked folder): the kind
    is the resolved name's, the resolved file is screened and Gmsh is handed exactly that name; a dangling
    link or a loop is not found. The .opt beside the link's name is screened too."""
    marker = tmp_path / "pwned"
    (tmp_path / "sub").mkdir()
    target = tmp_path / "sub" / target_name
    target.write_text(_evil(marker))
    path = _link_to(tmp_path, how, target, "m.geo")
    for opens in (lambda p: _body_opens(p, tmp_path, monkeypatch), lambda p: _tool_opens(p, tmp_path)):
        handed, why = opens(path)
        assert handed is None, (how, target_name)
        if how in ("dangling", "loop"):
            assert "not found" in why
        elif target.suffix.lower() in (".geo", ".msh"):
            assert str(target) in why and ("SystemCall" in why or "not a Gmsh mesh" in why)
        elif how == "folder":                       # (the name itself is lnk/real.txt)
            assert "must end in .geo or .msh" in why
        else:
            assert f"must end in .geo or .msh (it is a symbolic link to {target})" in why
    if how in ("dangling", "loop") or target.suffix.lower() not in (".geo", ".msh"):
        return
    target.write_text("p = 1;\n" if target.suffix.lower() == ".geo" else HEADER)
    assert mesh_file_kind(path) == (target, target.suffix.lower())
    assert input_files(path, tmp_path) == [target]
    for opens in (lambda p: _body_opens(p, tmp_path, monkeypatch), lambda p: _tool_opens(p, tmp_path)):
        assert opens(path)[0] == str(target)
    # the .opt beside the name given (Gmsh reads the one beside the name it opens: both are screened)
    for opt in (Path(f"{path}.opt"), Path(f"{target}.opt")):
        opt.write_text(_evil(marker))
        assert [f.command for f in scan(path, tmp_path).findings] == ["SystemCall"], opt
        assert _body_opens(path, tmp_path, monkeypatch)[0] is None and _tool_opens(path, tmp_path)[0] is None
        opt.unlink()
    assert not marker.exists()


READERS = [('Include "{}";', "Include"), ('Merge "{}";', "Merge"),
           ('MergeWithBoundingBox "{}";', "MergeWithBoundingBox"), ('s = ShapeFromFile("{}");', "ShapeFromFile"),
           ('x() = ListFromFile("{}");', "ListFromFile")]


@pytest.mark.parametrize("how", LINKS)
@pytest.mark.parametrize("line, command", READERS, ids=[c for _, c in READERS])
@pytest.mark.parametrize("target_name", ["y.geo", "y.stl", "y.msh", "y.txt"])
def test_a_script_that_names_a_link_is_refused(tmp_path, line, command, how, target_name):
    """Include, Merge, ShapeFromFile and ListFromFile of a link (to a file, to a link, to nothing, a loop):
    refused, since Gmsh would take the suffix, the .opt and the folder of relative paths from the link's
    name. A linked folder in the middle of the path is followed: the file itself is then screened."""
    (tmp_path / "sub").mkdir()
    target = tmp_path / "sub" / target_name
    target.write_text(_evil(tmp_path / "pwned"))
    name = f"x{Path(target_name).suffix}" if how != "folder" else None
    link = _link_to(tmp_path, how, target, name or "unused")
    text = os.path.relpath(link, tmp_path)
    path = _geo(tmp_path, line.format(text))
    findings = scan(path).findings
    shown = f'{command} "{text}"'
    if how != "folder":
        assert [(f.command, f.why) for f in findings] == [(shown, "names a symbolic link: name the file itself")]
        return
    # through a linked folder: what the file is decides, as for any file
    if command == "Include" or (command.startswith("Merge") and target.suffix in (".geo", ".msh")):
        assert [f.file for f in findings] == [target], findings
    elif command.startswith("Merge") and target.suffix == ".txt":
        assert [f.command for f in findings] == [shown]
    else:
        assert findings == [] and target in scan(path).files


def test_a_linked_folder_outside_the_scene_is_refused(tmp_path):
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "y.geo").write_text("p = 1;\n")
    scene = tmp_path / "scene"
    scene.mkdir()
    (scene / "lnk").symlink_to(outside, target_is_directory=True)
    path = _geo(scene, 'Include "lnk/y.geo";')
    assert "outside the scene's folder" in scan(path).findings[0].why


@pytest.mark.parametrize("how", ["file", "chain", "dangling", "loop"])
def test_an_opt_that_is_a_link_is_refused(tmp_path, how):
    """A .opt beside the mesh file or a Merge target that is a link: refused (Gmsh would read its Includes
    beside the link)."""
    (tmp_path / "sub").mkdir()
    real = tmp_path / "sub" / "o.txt"
    real.write_text("Mesh.Algorithm = 8;\n")
    mesh = tmp_path / "m.geo"
    mesh.write_text("p = 1;\n")
    _link_to(tmp_path, how, real, "m.geo.opt")
    assert [(f.command, f.why) for f in scan(mesh).findings] == [("option file", "names a symbolic link: name the "
                                                                                  "file itself")]
    data = tmp_path / "d.stl"
    data.write_text("solid x\nendsolid x\n")
    _link_to(tmp_path, how, real, "d.stl.opt")
    top = _geo(tmp_path, 'Merge "d.stl";', name="top.geo")
    assert any(f.file.name == "d.stl.opt" for f in scan(top).findings)


def test_gmsh_is_handed_the_resolved_mesh_file(tmp_path):
    """Real Gmsh: mesh.file = m.geo -> sub/real.geo, whose Include "part.geo" is sub/part.geo (screened);
    a part.geo beside the link (which Gmsh would read if it opened m.geo) is never run."""
    from mpi4py import MPI

    from fenics_plast.meshing import mesh_from_file
    marker = tmp_path / "pwned"
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "part.geo").write_text(GEO.read_text())
    (tmp_path / "sub" / "real.geo").write_text('Include "part.geo";\n')
    (tmp_path / "part.geo").write_text(_evil(marker))        # not screened: not read
    (tmp_path / "m.geo").symlink_to(tmp_path / "sub" / "real.geo")
    mesh, _, _, groups = mesh_from_file(MPI.COMM_SELF, tmp_path / "m.geo", {"cells_radial": 2, "cells_axial": 2},
                                        scene_dir=tmp_path)
    assert "bar" in groups and mesh.topology.index_map(2).size_local == 4
    assert not marker.exists()


# end to end: fenics-plast run on a scene whose mesh.file or meshed tool is one of the testers' files

def _e2e_case(folder: Path, marker: Path, case: str) -> str:
    """The mesh.file of a tester's case of issue 34 (each one Gmsh ran on the code before it), made in
    ``folder``."""
    evil, bar = _evil(marker), GEO.read_text()
    if case in ("evil.GEO", "evil.MSH"):
        (folder / case).write_text(evil)
    elif case == "script_link.geo":                      # m.geo -> real.txt, a script
        (folder / "real.txt").write_text(evil)
        (folder / case).symlink_to(folder / "real.txt")
    elif case == "opt_link.geo":                         # m.geo -> sub/real.geo, an unscreened m.geo.opt
        (folder / "sub").mkdir()
        (folder / "sub" / "real.geo").write_text(bar)
        (folder / case).symlink_to(folder / "sub" / "real.geo")
        (folder / f"{case}.opt").write_text(evil)
    else:                                               # Merge "x.geo" / "x.msh" with x.* -> y.stl, a script
        suffix = ".geo" if case == "merge_geo.geo" else ".msh"
        (folder / "y.stl").write_text(evil)
        (folder / f"x{suffix}").symlink_to(folder / "y.stl")
        (folder / case).write_text(bar + f'Merge "x{suffix}";\n')
    return case


@pytest.mark.parametrize("case", ["evil.GEO", "evil.MSH", "script_link.geo", "opt_link.geo", "merge_geo.geo",
                                  "merge_msh.geo"])
def test_cli_refuses_each_file_of_issue_34(tmp_path, case):
    """fenics-plast run with mesh.file naming each tester's file: exit 2, mesh.file named, the SystemCall
    never run, no output folder."""
    marker = tmp_path / "pwned"
    scene = tmp_path / "scene.toml"
    scene.write_text(re.sub(r"\[mesh\.parameters\]\n(.*\n)*?\n", "", BAR.read_text()))    # (.msh takes none)
    file = _e2e_case(tmp_path, marker, case)
    out = tmp_path / "out"
    rc, _, err = _run("run", scene, "--out", out, "--set", f'mesh.file="{file}"', cwd=tmp_path)
    assert rc == 2 and "mesh.file" in err and "Traceback" not in err, err
    assert not marker.exists() and not out.exists()


def test_cli_refuses_a_meshed_tool_in_upper_case(tmp_path):
    """[tools.wall] file = "tool.GEO" holding a SystemCall: exit 2 naming tools.wall, nothing run or written."""
    marker = tmp_path / "pwned"
    (tmp_path / "tool.GEO").write_text('Point(1) = {-1, 0, 0, 100};\nPoint(2) = {30, 0, 0, 100};\nLine(1) = {1, 2};\n'
                                       f'Physical Curve("wall") = {{1}};\nSystemCall "touch {marker}";\n')
    text = (ROOT / "demos" / "taylor_bar_wall.toml").read_text()
    text = text.replace('file = "../meshes/', f'file = "{ROOT}/meshes/')
    text = re.sub(r"\[tools\.wall\]\n(.*\n)*?\n", "", text)
    text = re.sub(r"\[boundary\.wall\]\n(.*\n)*?\n", "", text)
    if "[contact.face]" not in text:
        text += ('\n[contact.face]\ntool = "wall"\ngroup = "bottom"\nfriction = 0.0\nlaw = "coulomb"\n'
                 'penalty = 3.9e5\n')
    scene = tmp_path / "tool.toml"
    scene.write_text(text + '\n[tools.wall]\nshape = "mesh"\nfile = "tool.GEO"\ngroup = "wall"\n')
    out = tmp_path / "out"
    rc, _, err = _run("run", scene, "--out", out, cwd=tmp_path)
    assert rc == 2 and "tools.wall" in err and "SystemCall runs a program" in err, err
    assert not marker.exists() and not out.exists()
