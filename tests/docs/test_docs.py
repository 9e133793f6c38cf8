"""The documentation is true: it builds, and what it says about the package matches the package.

* ``mkdocs build --strict`` (docs/, mkdocs.yml, the API reference from the
  docstrings) builds without warnings, as CI would; skipped when the docs tools
  (the ``test`` or ``docs`` extra: mkdocs, mkdocstrings[python]) are not installed.
* Every ``gibbsimpact`` command line written in README.md and docs/*.md uses a
  real subcommand and real options of that subcommand (read from the argparse
  parser the command line itself uses), and docs/case-format.md describes every
  option of every subcommand.
* examples/README.md lists exactly the scripts in examples/; the case files and
  examples the README names exist, and it names all of them; the README's
  relative links point at files that exist; every "theory.md §N" cited anywhere
  exists as a numbered section of docs/theory.md; .ci/run runs the README's test command.
"""

import argparse
import re
import subprocess
import sys
from pathlib import Path

import pytest

import gibbsimpact
from gibbsimpact.cli import commands as cli

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
DOCS = sorted((ROOT / "docs").glob("*.md"))


# -- the docs build --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    pytest.importorskip("mkdocs")
    pytest.importorskip("mkdocstrings")
    pytest.importorskip("mkdocstrings_handlers.python")
    site_dir = tmp_path_factory.mktemp("site")
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site_dir)],
        cwd=ROOT, capture_output=True, text=True, timeout=120,
    )
    return proc, site_dir


def test_mkdocs_build_strict_without_warnings(site):
    proc, _ = site
    output = proc.stdout + proc.stderr
    assert proc.returncode == 0, output
    warnings = [line for line in output.splitlines() if "WARNING" in line or "ERROR" in line]
    assert not warnings, "\n".join(warnings)


def test_api_reference_documents_the_public_api(site):
    proc, site_dir = site
    assert proc.returncode == 0, proc.stdout + proc.stderr
    page = (site_dir / "api" / "index.html").read_text(encoding="utf-8")
    ids = set(re.findall(r'id="(gibbsimpact\.[\w.]+)"', page))
    names = {i.rsplit(".", 1)[-1] for i in ids}
    missing = [n for n in gibbsimpact.__all__ if n != "__version__" and n not in names]
    assert not missing, f"public names without an entry in docs/api.md: {missing}"
    for required in ("gibbsimpact.dynamics.gibbs_appell.forward_dynamics", "gibbsimpact.dynamics.kinematics.frames",
                     "gibbsimpact.simulation.validity.check_state", "gibbsimpact.study.sweep.sweep"):
        assert required in ids


# -- command lines in the docs ---------------------------------------------------------------


def real_options() -> dict:
    """{subcommand: set of option strings} of the real parser; "" holds the top-level options."""
    parser = cli.build_parser()
    options = {"": {s for a in parser._actions for s in a.option_strings}}
    (subparsers,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    for name, sub in subparsers.choices.items():
        options[name] = {s for a in sub._actions for s in a.option_strings}
    return options


# A command starts a code line or an inline code span (after a shell prompt, "&&", ";" or
# "python -m"), so "import gibbsimpact as gi" and "gibbsimpact: error: ..." are not commands.
_COMMAND = re.compile(r"(?:^|&&|;|\$)\s*(?:python3? -m )?gibbsimpact(?=\s)(?P<args>[^;&]*)")
_OPTION = re.compile(r"^-{1,2}[A-Za-z][\w-]*")


def code_lines(text: str):
    """(line number, text) of every line of a fenced code block and of every inline code span.

    Indented lines of a code block that start with "[" or "-" continue the command above
    (a synopsis wrapped over several lines); they are joined to it.
    """
    out, fence, lines = [], None, text.splitlines()
    for no, line in enumerate(lines, start=1):
        stripped = line.strip()
        if stripped.startswith("```"):
            fence = None if fence is not None else no
            continue
        if fence is not None:
            code = line.split(" #", 1)[0]
            if out and out[-1][2] == fence and line[:1].isspace() and stripped[:1] in ("[", "-"):
                out[-1] = (out[-1][0], out[-1][1] + " " + code.strip(), fence)
            else:
                out.append((no, code, fence))
        else:
            out.extend((no, span, None) for span in re.findall(r"`([^`]+)`", line))
    return [(no, code) for no, code, _ in out]


def commands(path: Path):
    """(line number, subcommand or "", [option strings]) of every gibbsimpact command line in a file."""
    found = []
    for no, code in code_lines(path.read_text(encoding="utf-8")):
        for m in _COMMAND.finditer(code):
            words = [w.strip("[]{}(),.|") for w in m["args"].split()]
            words = [w for w in words if w]
            sub = words[0] if words and not words[0].startswith("-") else ""
            opts = [_OPTION.match(w)[0] for w in words if _OPTION.match(w)]
            found.append((no, sub, opts))
    return found


def test_the_docs_name_command_lines():
    # The scanner finds the command lines it is meant to check (so the test below is not vacuous).
    found = {sub for path in [README, *DOCS] for _, sub, _ in commands(path)}
    assert {"run", "show", "equations", "sweep"} <= found, found


@pytest.mark.parametrize("path", [README, *DOCS], ids=lambda p: p.name)
def test_command_lines_use_real_subcommands_and_options(path):
    options = real_options()
    bad = []
    for no, sub, opts in commands(path):
        if sub not in options:
            bad.append(f"{path.name}:{no}: gibbsimpact {sub}: no such command (commands: {sorted(options)[1:]})")
            continue
        for opt in opts:
            if opt not in options[sub]:
                bad.append(f"{path.name}:{no}: gibbsimpact {sub} {opt}: no such option "
                           f"(options: {sorted(options[sub])})")
    assert not bad, "\n".join(bad)


def command_line_section() -> str:
    text = (ROOT / "docs" / "case-format.md").read_text(encoding="utf-8")
    start = text.index("## The command line")
    end = text.index("\n## ", start + 1)
    return text[start:end]


@pytest.mark.parametrize("sub", ["run", "show", "equations", "sweep"])
def test_case_format_describes_every_option(sub):
    section = command_line_section()
    assert re.search(rf"^gibbsimpact {sub}\b", section, re.M), f"no synopsis of gibbsimpact {sub}"
    # Described: in backticks in the command's own subsection ("### `run`"), not only in the synopsis.
    start = section.index(f"### `{sub}`")
    end = section.find("\n### ", start + 1)
    own = section[start:end if end > 0 else None]
    missing = [opt for opt in sorted(real_options()[sub]) if opt not in ("-h", "--help")
               and not re.search(rf"`{re.escape(opt)}\b", own)]
    assert not missing, f"docs/case-format.md, '### `{sub}`': options not described: {missing}"


def test_every_subcommand_is_in_the_command_line_section():
    section = command_line_section()
    missing = [sub for sub in real_options() if sub and f"gibbsimpact {sub}" not in section]
    assert not missing, missing


# -- examples, case files, links -------------------------------------------------------------


def test_examples_readme_lists_exactly_the_scripts():
    text = (ROOT / "examples" / "README.md").read_text(encoding="utf-8")
    listed = re.findall(r"^\|\s*`([\w.-]+\.py)`\s*\|", text, re.M)
    scripts = sorted(p.name for p in (ROOT / "examples").glob("*.py"))
    assert len(listed) == len(set(listed)), f"listed twice: {sorted(n for n in listed if listed.count(n) > 1)}"
    assert sorted(listed) == scripts, (f"examples/README.md lists {sorted(set(listed) - set(scripts))} "
                                       f"that do not exist and misses {sorted(set(scripts) - set(listed))}")


@pytest.mark.parametrize("folder, suffix", [("cases", "toml"), ("examples", "py")])
def test_readme_names_exactly_the_case_files_and_examples(folder, suffix):
    text = README.read_text(encoding="utf-8")
    named = set(re.findall(rf"\b{folder}/([\w.-]+\.{suffix})\b", text))
    present = {p.name for p in (ROOT / folder).glob(f"*.{suffix}")}
    assert not named - present, f"README.md names {folder}/ files that do not exist: {sorted(named - present)}"
    assert not present - named, f"README.md does not name {folder}/ files: {sorted(present - named)}"


def test_readme_links_point_at_files():
    text = README.read_text(encoding="utf-8")
    targets = re.findall(r"\]\(([^)\s]+)\)", text)
    local = [t.split("#", 1)[0] for t in targets if not re.match(r"[a-z]+:", t) and not t.startswith("#")]
    assert local, "no relative links found"
    missing = [t for t in local if t and not (ROOT / t).exists()]
    assert not missing, f"README.md links to missing files: {missing}"



def test_ci_runs_the_readme_test_command():
    # CI (.ci/run) runs "the README's test command": the first pytest command line of the README (its
    # options: xdist workers, distribution) is the one .ci/run runs, so that one change edits both.
    readme = re.findall(r"^python -m pytest\b.*$", README.read_text(encoding="utf-8"), re.M)
    ci = re.findall(r"^python -m pytest\b.*$", (ROOT / ".ci" / "run").read_text(encoding="utf-8"), re.M)
    assert readme and ci == readme[:1], f"README's test command {readme[:1]} is not .ci/run's {ci}"


def slug(heading: str) -> str:
    """The anchor mkdocs (pymdownx slugify, lower case) and GitHub give a heading."""
    return re.sub(r"\s", "-", re.sub(r"[^\w\s-]", "", heading.strip().lower()))


def test_readme_links_into_the_docs_name_real_sections():
    text = README.read_text(encoding="utf-8")
    links = re.findall(r"\]\((docs/[\w.-]+\.md)#([^)\s]+)\)", text)
    assert links, "no links to sections of docs/ found"
    bad = []
    for page, anchor in links:
        headings = re.findall(r"^#{1,6} (.+)$", (ROOT / page).read_text(encoding="utf-8"), re.M)
        if anchor not in {slug(h) for h in headings}:
            bad.append(f"{page}#{anchor}")
    assert not bad, f"README.md links to sections that do not exist: {bad}"


def theory_sections() -> set:
    text = (ROOT / "docs" / "theory.md").read_text(encoding="utf-8")
    return set(re.findall(r"^#{2,4} (\d+(?:\.\d+)*)[. ]", text, re.M))


def test_theory_sections_are_numbered():
    sections = theory_sections()
    top = sorted(int(s) for s in sections if "." not in s)
    assert top == list(range(1, len(top) + 1)) and len(top) >= 15, top


def test_citations_of_theory_sections_exist():
    # "theory.md §7.3", "theory.md section 7.3", "[the model §7](theory.md#...)" in the docs, the
    # README, the case files' headers, the examples and the docstrings.
    sections = theory_sections()
    # A citation may wrap onto the next comment line ("docs/theory.md\n# section 7.4").
    cite = re.compile(r"theory(?:\.md)?\)?,?[\s#]*(?:§|sections?\s+)(\d+(?:\.\d+)*)"
                      r"|the model §(\d+(?:\.\d+)*)")
    files = [README, *DOCS, *(ROOT / "cases").glob("*.toml"), *(ROOT / "examples").glob("*.py"),
             *(ROOT / "src").rglob("*.py")]
    bad, n_cited = [], 0
    for path in files:
        text = path.read_text(encoding="utf-8")
        for m in cite.finditer(text):
            number, n_cited = m[1] or m[2], n_cited + 1
            if number.rstrip(".") not in sections:
                no = text.count("\n", 0, m.start()) + 1
                bad.append(f"{path.relative_to(ROOT)}:{no}: theory.md §{number} does not exist")
    assert n_cited >= 10, n_cited
    assert not bad, "\n".join(bad)


def test_api_page_shows_every_row_of_the_joint_kind_table():
    # docs/api.md's table of joint kinds is written by hand: each row must say what JOINT_KINDS says.
    from gibbsimpact.model.joints import JOINT_KINDS
    text = (ROOT / "docs" / "api.md").read_text()
    yes = lambda b: "yes" if b else "no"  # noqa: E731
    for k in JOINT_KINDS.values():
        coordinate = f"`{k.symbol}_i` [{k.unit}]" if k.has_coordinate else "none"
        row = (f"| `{k.code}` | `gi.{k.name}` | {coordinate} | {yes(k.turns)} | {yes(k.prismatic)} | "
               f"{yes(k.carriage)} | {yes(k.guide)} | {k.kernel_code} |")
        assert row in text, row
