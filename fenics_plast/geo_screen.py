"""Screening of Gmsh mesh files before Gmsh reads them: a scene's mesh is data, not a program.

Gmsh's script language (the ``.geo`` format) can run programs and touch files. Read from the
grammar of Gmsh 4.8 (``Parser/Gmsh.y``, ``Parser/Gmsh.l``, ``Common/OpenFile.cpp``; unchanged in the
newest Gmsh), these are the ways a script reaches outside the mesh, and what this module does with
each:

=================================================  ============================================
Gmsh                                               screen
=================================================  ============================================
``SystemCall "cmd";``, ``System``,                 refused: runs a program
``NonBlockingSystemCall``, ``OnelabRun``
(both forms), ``Shell`` and ``DeleteFile``
(not Gmsh 4.8 commands; refused in case a
later Gmsh adds them), ``Delete File``
``Printf(...) > "file";`` / ``>> "file"``          refused: writes a file (plain ``Printf`` is fine)
``Save "file";``, ``Save View[i] "file";``,        refused: write files
``Print "file";``, ``CreateDir "dir";``
``SendToServer View[i] "..."``                     refused: talks to a ONELAB server
``Plugin(Name)...``                                refused: several plugins write files
``Exit;``                                          refused: ends the calling process (the run
                                                   would stop with status 0 and no message)
``Include "file";``                                screened recursively; the file must lie in an
                                                   allowed folder (below)
``Merge "file";``, ``MergeWithBoundingBox``        by the suffix, as Gmsh takes it: exactly ``.step
                                                   .STEP .stp .STP .iges .IGES .igs .IGS .brep
                                                   .brp .BRP .stl .STL`` (Gmsh compares case) are
                                                   data; ``.msh`` in any case must start with a
                                                   mesh header (Gmsh reads any other suffix,
                                                   ``.msh`` and ``.Stl`` too, by its first line: a
                                                   mesh header, or else a script); ``.geo`` in any
                                                   case is screened like an Include; any other
                                                   suffix is refused (Gmsh would read it as a
                                                   script, run ``gunzip`` on ``.gz``, register
                                                   ``.py``/``.exe`` as a solver); in an allowed
                                                   folder
``ShapeFromFile("f")``, ``ListFromFile("f")``      reads a file: in an allowed folder
``StringToName[...]`` / ``S2N[...]``               a name built from a string could spell any
                                                   command: allowed with a literal string only,
                                                   which is then screened as the name it spells
=================================================  ============================================

Every file name in Include, Merge, ShapeFromFile and ListFromFile must be a string literal (``Include
StrCat(dir, "x.geo")`` cannot be screened and is refused). Gmsh also merges ``<file>.opt`` after
every file it opens with Merge (the mesh file itself included, and a ``.opt`` itself) and reads it as a
script: those files are screened too when they exist. ``Sleep``, ``Abort``, ``GetEnv``, options and
everything else that builds or meshes geometry are allowed.

Symbolic links: Gmsh acts on the name it is given (its suffix, the ``.opt`` beside it, the folder
relative Includes are read from), the screen on the file. So the mesh file is resolved first
(:func:`mesh_file_kind`: the callers hand Gmsh the resolved name and take its kind from it, ``.geo``
or ``.msh`` in any case), and the ``.opt`` beside both names is screened; a file named in a script
(Include, Merge, ShapeFromFile, ListFromFile) or a ``.opt`` that is itself a symbolic link is refused
(a link to a folder higher in the path is followed; the file must still lie in an allowed folder), and
so is a loop of links.

Allowed folders: the scene file's folder and everything below it, and the package's ``meshes/``
folder (its shipped geometries). The mesh file itself may lie elsewhere (``mesh.file`` names it).

The screen reads the text as Gmsh's lexer does: ``//`` and ``/* */`` comments and ``"..."`` or
``'...'`` strings (no escapes, may span lines) are skipped, so a command word in a comment or string
is not a command, and a command hidden behind one is still found. It checks every branch of ``If``
and every ``Macro``, whether Gmsh would run it or not. A refusal raises :class:`GeoScreenError`
naming the file, the line and the command. ``fenics-plast run --trust-mesh-script`` skips the screen.

:func:`input_files` lists the files a mesh file makes Gmsh read (checkpoints fingerprint them).
This module imports neither gmsh nor dolfinx.
"""
from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["MESH_DIR", "GeoScreenError", "Finding", "Scan", "scan", "screen", "input_files", "mesh_file_kind",
           "DATA_SUFFIXES", "MESH_HEADERS"]

#: Merge targets Gmsh reads as data (Common/OpenFile.cpp, MergeFile): exact suffixes, Gmsh compares case
DATA_SUFFIXES = (".msh", ".step", ".STEP", ".stp", ".STP", ".iges", ".IGES", ".igs", ".IGS", ".brep", ".brp",
                 ".BRP", ".stl", ".STL")
#: first-line prefixes that make Gmsh read a file as a mesh (anything else without a known suffix is a script)
MESH_HEADERS = ("$MeshFormat", "$Comments", "$PTS", "$NO", "$PARA", "$ELM")

# command words that act when followed by a string (or a name): String__Index StringExpr ';'
_RUNS = {"SystemCall": "runs a program", "System": "runs a program", "NonBlockingSystemCall": "runs a program",
         "Shell": "runs a program", "OnelabRun": "runs a program (a ONELAB client)",
         "Save": "writes a file", "Print": "writes a file", "CreateDir": "creates a folder",
         "DeleteFile": "deletes a file", "SendToServer": "talks to a ONELAB server"}
# tokens refused wherever they appear
_ALWAYS = {"OnelabRun": "runs a program (a ONELAB client)", "Plugin": "runs a Gmsh plugin (some write files)",
           "Exit": "ends the process that reads the mesh (the run would stop without a word)"}
_READS = ("Include", "Merge", "MergeWithBoundingBox")
_READ_FUNCS = ("ShapeFromFile", "ListFromFile")
_TO_NAME = ("StringToName", "S2N")
# what may follow a command word when it is only a variable's name: then it is not a command
_VARIABLE_USE = {"=", "+=", "-=", "*=", "/=", "[", "~", ";", ",", ")", "}", "]", "+", "-", "*", "/", "^", "%",
                 "<", ">", "<=", ">=", "==", "!=", "&&", "||", "?", ":", ".", "::", "++", "--", "|", "&", "!"}
_MAX_FILES = 1000       # Includes of Includes...: a bound, so that a cycle or a flood ends
_LINK = "names a symbolic link: name the file itself"
#: the package's shipped geometries (meshes/; FENICS_PLAST_MESHES overrides): trusted for Include and Merge
MESH_DIR = Path(os.environ.get("FENICS_PLAST_MESHES", Path(__file__).resolve().parent.parent / "meshes"))


class GeoScreenError(ValueError):
    """A mesh file uses a command that runs programs or touches files (or cannot be screened)."""


@dataclass(frozen=True)
class Finding:
    """One refused use: the file, its line (1-based), the command and why it is refused."""
    file: Path
    line: int
    command: str
    why: str

    def __str__(self) -> str:
        return f"{self.file}, line {self.line}: {self.command} {self.why}"


@dataclass
class Scan:
    """What :func:`scan` found: the refused uses (in reading order) and every file read (the mesh
    file first, each once, resolved)."""
    findings: list[Finding] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)


@dataclass(frozen=True)
class _Tok:
    kind: str       # "id", "str", "num", "op"
    text: str
    line: int


_OPS = ("::", "+=", "-=", "*=", "/=", "<=", ">=", "==", "!=", "&&", "||", "++", "--", ">>", "<<", "...")
_ID = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_NUM = re.compile(r"(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?")


def _tokens(text: str) -> tuple[list[_Tok], tuple[int, str] | None]:
    """Gmsh's lexer, as far as the screen needs it: the tokens, and (line, problem) when an
    unterminated string or comment stops the reading (else None)."""
    out: list[_Tok] = []
    i, n, line = 0, len(text), 1
    while i < n:
        c = text[i]
        if c == "\n":
            line += 1
            i += 1
        elif c in " \t\r\f\v":
            i += 1
        elif text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            if j < 0:
                return out, (line, "a comment that never ends (/* without */)")
            line += text.count("\n", i, j)
            i = j + 2
        elif c in "\"'":
            j = text.find(c, i + 1)
            if j < 0:
                return out, (line, f"a string that never ends ({c} without its closing {c})")
            out.append(_Tok("str", text[i + 1:j], line))
            line += text.count("\n", i, j)
            i = j + 1
        elif c.isalpha() or c == "_":
            m = _ID.match(text, i)
            out.append(_Tok("id", m.group(), line))
            i = m.end()
        elif c.isdigit() or (c == "." and i + 1 < n and text[i + 1].isdigit()):
            m = _NUM.match(text, i)
            out.append(_Tok("num", m.group(), line))
            i = m.end()
        else:
            op = next((o for o in _OPS if text.startswith(o, i)), c)
            out.append(_Tok("op", op, line))
            i += len(op)
    return out, None


def _inside(path: Path, roots) -> bool:
    return any(path == r or r in path.parents for r in roots)


def _resolve(path: Path) -> Path | None:
    """``path`` with every symbolic link resolved, or None for a loop of links."""
    try:
        return path.resolve()
    except (OSError, RuntimeError):     # (Python < 3.13 raises RuntimeError for a loop)
        return None


def _kind(path: Path) -> str:
    """How Gmsh's MergeFile takes ``path`` by its name: "data" (an exact data suffix), "mesh" (``.msh`` in
    any case: a mesh if its first line is a mesh header, else a script), "geo" (``.geo`` in any case: a
    script) or "other" (another suffix: a script, or a file handed to another program)."""
    suffix = path.suffix
    if suffix in DATA_SUFFIXES and suffix != ".msh":
        return "data"
    return {".msh": "mesh", ".geo": "geo"}.get(suffix.lower(), "other")


def mesh_file_kind(path) -> tuple[Path, str]:
    """The file Gmsh is to open for the mesh file ``path`` (every symbolic link resolved: hand Gmsh this
    name, so that it decides the format, finds ``.opt`` and resolves Includes as the screen did) and its
    kind from the resolved name, suffix compared without case: ".geo", ".msh" or "" (anything else)."""
    resolved = _resolve(Path(path)) or Path(path)
    suffix = resolved.suffix.lower()
    return resolved, suffix if suffix in (".geo", ".msh") else ""


def _first_line(path: Path) -> str:
    try:
        with open(path, "rb") as f:
            return f.readline(256).decode("latin-1")
    except OSError:
        return ""


class _Scanner:
    def __init__(self, roots):
        self.roots = [Path(r).resolve() for r in roots]
        self.result = Scan()
        self.seen: set[Path] = set()

    def refuse(self, file, line, command, why):
        self.result.findings.append(Finding(file, line, command, why))

    def add(self, path: Path) -> bool:
        """Record a file read; False when it was seen already (or too many)."""
        if path in self.seen or len(self.seen) >= _MAX_FILES:
            return False
        self.seen.add(path)
        self.result.files.append(path)
        return True

    def opt_chain(self, path: Path) -> None:
        """Gmsh merges ``<file>.opt`` after every file it merges (``path`` as Gmsh names it), as a script,
        and that file's ``.opt`` in turn. A ``.opt`` that is a symbolic link is refused (Gmsh would resolve
        its Includes beside the link)."""
        opt = Path(str(path) + ".opt")
        if opt.is_symlink():
            self.refuse(opt, 1, "option file", _LINK)
        elif opt.is_file():
            self.merged(opt.resolve())

    def merged(self, path: Path) -> None:
        """A file Gmsh opens with MergeFile (the mesh file itself, a Merge target, a ``.opt``), ``path``
        resolved. Its kind as Gmsh decides it: an exact data suffix is data; any other suffix makes Gmsh
        look at the first line (a mesh header: a mesh; anything else: a script)."""
        kind = _kind(path)
        if kind == "data":
            self.add(path)
        elif kind == "mesh":
            if self.add(path) and not _first_line(path).startswith(MESH_HEADERS):
                self.refuse(path, 1, "mesh file", f"is not a Gmsh mesh: its first line is not $MeshFormat, and "
                                                  f"Gmsh reads such a file as a script")
        else:                       # .geo in any case, .opt, any other suffix: screened as a script
            self.script(path)
        self.opt_chain(path)

    def file_arg(self, toks, k, file, command):
        """The file named by the string literal at toks[k] (resolved like Gmsh: relative to the file
        that names it), or None after a refusal."""
        t = toks[k] if k < len(toks) else None
        if t is None or t.kind != "str":
            line = t.line if t is not None else (toks[-1].line if toks else 1)
            self.refuse(file, line, command, "names its file with an expression: write the file name as a "
                                             "string (\"name.geo\") so that it can be screened")
            return None
        named = Path(t.text)
        named = named if named.is_absolute() else file.parent / named
        if named.is_symlink():      # Gmsh would act on the link's name (suffix, .opt, relative paths)
            self.refuse(file, t.line, f'{command} "{t.text}"', _LINK)
            return None
        target = _resolve(named)
        if target is None:
            self.refuse(file, t.line, f'{command} "{t.text}"', "names a path that cannot be resolved (a loop of "
                                                               "symbolic links)")
            return None
        if not _inside(target, self.roots):
            self.refuse(file, t.line, f'{command} "{t.text}"',
                        f"reads a file outside the scene's folder ({', '.join(map(str, self.roots))})")
            return None
        if not target.is_file():
            self.refuse(file, t.line, f'{command} "{t.text}"', "names a file that does not exist")
            return None
        return target

    def script(self, path: Path) -> None:
        if not self.add(path):
            return
        try:
            text = path.read_bytes().decode("utf-8", errors="replace")
        except OSError as e:
            self.refuse(path, 1, "file", f"cannot be read: {e.strerror or e}")
            return
        toks, problem = _tokens(text)
        if problem:
            self.refuse(path, problem[0], "text", f"cannot be screened: {problem[1]}")
        nxt = (lambda k: toks[k] if k < len(toks) else None)
        k = 0
        while k < len(toks):
            t = toks[k]
            k += 1
            if t.kind != "id":
                continue
            name, after = t.text, k
            if name in _TO_NAME:        # S2N["..."]: the name the literal spells, else unscreenable
                a, b, c = nxt(k), nxt(k + 1), nxt(k + 2)
                if a is not None and a.text == "[" and b is not None and b.kind == "str" and c is not None \
                        and c.text == "]":
                    name, after = b.text, k + 3
                    if not _ID.fullmatch(name):
                        continue
                else:
                    self.refuse(path, t.line, name, "builds a name from a computed string, which could spell any "
                                                    "command: use a plain name (or a string literal)")
                    continue
            follow = nxt(after)
            command_form = follow is not None and follow.text not in _VARIABLE_USE
            if name in _ALWAYS:
                self.refuse(path, t.line, name, _ALWAYS[name])
            elif name in _RUNS and command_form:
                self.refuse(path, t.line, name, _RUNS[name])
            elif name == "Delete" and follow is not None and follow.text == "File":
                self.refuse(path, t.line, "Delete File", "deletes a file")
            elif name == "Printf" and follow is not None and follow.text == "(":
                depth, j = 0, after
                while j < len(toks):
                    depth += {"(": 1, ")": -1}.get(toks[j].text, 0) if toks[j].kind == "op" else 0
                    j += 1
                    if depth == 0:
                        break
                end = nxt(j)
                if end is not None and end.text in (">", ">>"):
                    self.refuse(path, end.line, f"Printf(...) {end.text}", "writes to a file")
            elif name in _READS and command_form:
                target = self.file_arg(toks, after, path, name)
                if target is None:
                    continue
                if name == "Include":
                    self.script(target)
                elif _kind(target) != "other":
                    self.merged(target)
                else:
                    self.refuse(path, toks[after].line, f'{name} "{toks[after].text}"',
                                f"reads a file Gmsh would treat as a script or hand to another program: Merge "
                                f"takes {', '.join(s for s in DATA_SUFFIXES if s.islower())} (or .geo)")
            elif name in _READ_FUNCS and follow is not None and follow.text == "(":
                target = self.file_arg(toks, after + 1, path, name)
                if target is not None:
                    self.add(target)


def _roots(mesh_file: Path, scene_dir) -> list[Path]:
    return [Path(scene_dir) if scene_dir is not None else Path(mesh_file).parent, MESH_DIR]


def scan(mesh_file, scene_dir=None) -> Scan:
    """Screen the mesh file ``mesh_file`` (.geo or .msh) and everything it makes Gmsh read. Allowed
    folders: ``scene_dir`` (default: the mesh file's folder) and below, and the package's meshes/."""
    given = Path(mesh_file).absolute()
    path = _resolve(given)
    s = _Scanner(_roots(path or given, scene_dir))
    if path is None:
        s.refuse(given, 1, "mesh file", "cannot be resolved (a loop of symbolic links)")
        return s.result
    s.merged(path)
    if path != given:           # a link: Gmsh is handed ``path``; the .opt beside the link's name is screened too
        s.opt_chain(given)
    return s.result


def screen(mesh_file, scene_dir=None) -> list[Path]:
    """:func:`scan`, raising :class:`GeoScreenError` at the first refused use (the message names the
    file, the line and the command, and how many more there are). Returns the files read."""
    result = scan(mesh_file, scene_dir)
    if result.findings:
        first, more = result.findings[0], len(result.findings) - 1
        raise GeoScreenError(f"{first}: refused (a mesh script may only build and mesh geometry"
                             + (f"; {more} more such use(s)" if more else "")
                             + "). If you trust this script, run with --trust-mesh-script")
    return result.files


def input_files(mesh_file, scene_dir=None) -> list[Path]:
    """The files Gmsh reads for ``mesh_file`` (itself, its Includes and Merges, ``.opt`` files), as far
    as string literals name them; refusals are ignored here."""
    return scan(mesh_file, scene_dir).files


def _self_check() -> None:   # pragma: no cover - a development aid: python -m fenics_plast.geo_screen FILE...
    import sys
    status = 0
    for f in sys.argv[1:]:
        r = scan(f)
        for x in r.findings:
            print(x)
            status = 1
    sys.exit(status)


if __name__ == "__main__":   # pragma: no cover
    _self_check()
