"""A mesh script is screened before Gmsh reads it (issue 21, item 1; fenics_plast/geo_screen.py).

Each command of Gmsh 4.8's script language that runs a program or touches a file is refused with
its file, line and command; comments and strings do not fool the screen either way; Include and
Merge are followed (and kept to the scene's folder and meshes/); the files Gmsh reads besides the
script itself (``<file>.opt``, a ``.msh`` that is really a script) are screened too; every shipped
``.geo`` passes. Through the CLI: ``--set mesh.file=evil.geo`` with a ``SystemCall`` exits 2 naming
``mesh.file`` and runs nothing; ``--trust-mesh-script`` lets it run.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from fenics_plast.geo_screen import GeoScreenError, input_files, scan, screen

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
