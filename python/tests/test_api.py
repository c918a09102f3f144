"""The public API: shipped stubs that match the code, docstrings everywhere, a function per
command of the `align3d` tool, keywords named after its flags."""

import ast
import inspect
import pathlib
import re
import subprocess

import pytest

import align3d

STUB = pathlib.Path(align3d.__file__).with_name("__init__.pyi")


def stub_tree():
    return {node.name: node for node in ast.parse(STUB.read_text()).body
            if isinstance(node, (ast.FunctionDef, ast.ClassDef))}


def parameters(function_node):
    a = function_node.args
    names = [p.arg for p in a.posonlyargs + a.args]
    return names, [p.arg for p in a.kwonlyargs]


def code_parameters(function):
    sig = inspect.signature(function)
    positional = [n for n, p in sig.parameters.items()
                  if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    keyword = [n for n, p in sig.parameters.items() if p.kind == p.KEYWORD_ONLY]
    return positional, keyword


def test_the_package_ships_its_stubs_and_py_typed():
    assert STUB.is_file()
    assert STUB.with_name("py.typed").is_file()


@pytest.mark.parametrize("name", align3d.__all__)
def test_every_public_name_is_in_the_stub_with_the_same_parameters(name):
    stubs = stub_tree()
    assert name in stubs, f"{name} missing from {STUB.name}"
    obj = getattr(align3d, name)
    node = stubs[name]
    if inspect.isfunction(obj):
        assert parameters(node) == code_parameters(obj)
        return
    members = {n.name: n for n in node.body if isinstance(n, ast.FunctionDef)}
    for member, value in vars(obj).items():
        if member.startswith("_") and member not in ("__init__", "__len__"):
            continue
        if isinstance(value, property) or inspect.isfunction(value):
            assert member in members, f"{name}.{member} missing from the stub"
        if inspect.isfunction(value):
            assert parameters(members[member]) == code_parameters(value), f"{name}.{member}"
    for base in obj.__mro__[1:]:  # inherited public members (Result from its base)
        if base.__module__.startswith("align3d"):
            for member, value in vars(base).items():
                if not member.startswith("_") and isinstance(value, property):
                    assert member in members, f"{name}.{member} missing from the stub"


@pytest.mark.parametrize("name", align3d.__all__)
def test_everything_public_has_a_docstring(name):
    obj = getattr(align3d, name)
    assert inspect.getdoc(obj), name
    if inspect.isclass(obj):
        for member, value in inspect.getmembers(obj):
            if member.startswith("_") or not (isinstance(value, property) or callable(value)):
                continue
            if issubclass(obj, BaseException) and member in dir(Exception):
                continue
            assert inspect.getdoc(value), f"{name}.{member}"


def test_every_cli_command_has_a_function(cli):
    help_text = subprocess.run([str(cli), "--help"], capture_output=True, text=True).stdout
    section = help_text[help_text.index("Subcommands:"):]
    commands = re.findall(r"^  ([a-z][a-z-]*)\s", section, re.M)
    assert commands, help_text
    # `align3d batch` is the module align3d.batch (Dask is imported only there).
    functions = {"batch": lambda: align3d.batch.register_pairs}
    for command in commands:
        function = functions.get(command, lambda: getattr(align3d, command.replace("-", "_")))()
        assert callable(function), command


def flags(cli, command):
    text = subprocess.run([str(cli), command, "--help"], capture_output=True, text=True).stdout
    # Option lines only ("  -h,--help ...", "  --max-iterations INT ..."), not descriptions.
    found = re.findall(r"^\s+(?:-\w,\s*)?--([a-z][a-z-]*)", text, re.M)
    assert found, text
    return {f.replace("-", "_") for f in found}


# The command line's flags that are not keywords, and why.
NOT_KEYWORDS = {
    "help": "Python's help()",
    "quiet": "the package prints nothing (no progress line, no summary)",
    "robust": "the same as fit='robust', the default",
    "global": "a Python keyword: global_method",
}


@pytest.mark.parametrize(
    "command, function",
    [("register", align3d.register), ("rectify", align3d.rectify), ("synth", align3d.synth),
     ("evaluate", align3d.evaluate), ("demo", align3d.demo), ("convert", align3d.convert),
     ("ppf-model", align3d.ppf_model)],
)
def test_keywords_are_named_after_the_cli_flags(cli, command, function):
    keywords = set(inspect.signature(function).parameters)
    for flag in flags(cli, command) - set(NOT_KEYWORDS):
        assert flag in keywords, f"align3d {command} --{flag.replace('_', '-')} has no keyword"
    if command == "register":
        assert "global_method" in keywords


def test_version():
    assert re.fullmatch(r"\d+\.\d+\.\d+", align3d.__version__)


def test_one_version_everywhere(cli):
    # CMake's project() version, the one place it is written: the package's metadata, the
    # module's __version__, `align3d --version` and the package's own `align3d` command.
    import importlib.metadata
    import sys

    cmake = (pathlib.Path(__file__).resolve().parents[2] / "CMakeLists.txt").read_text()
    version = re.search(r"project\(align3d VERSION ([0-9.]+)", cmake).group(1)
    assert align3d.__version__ == version
    assert importlib.metadata.version("align3d") == version
    for command in ([str(cli)], [sys.executable, "-m", "align3d._cli"]):
        run = subprocess.run(command + ["--version"], capture_output=True, text=True)
        assert (run.returncode, run.stdout, run.stderr) == (0, f"align3d {version}\n", "")
    run = subprocess.run([sys.executable, "-m", "align3d._cli", "register", "--nonsense"],
                         capture_output=True, text=True)
    assert run.returncode == 2 and "see align3d --help" in run.stderr
