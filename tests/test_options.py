"""The typed options (depixel/options.py, docs/design.md "Options"): checked once when made,
built at the edges from the same keywords everywhere, digested whole into a file's stamp,
and no function threading a dozen loose keywords instead."""
from __future__ import annotations

import ast
import dataclasses
import inspect
from pathlib import Path

import pytest
from conftest import FIXTURES, ROOT, art

import depixel
from depixel import api
from depixel.errors import ParameterError
from depixel.files import convert as files
from depixel.files import stamp as stamps
from depixel.frozen import added
from depixel.options import ConvertOptions, Limits, OutputOptions, PrepareOptions
from depixel.prepare.sheet_json import SheetJson

MAX_PARAMETERS = 8
SPRITE = art("""
    .##.
    #rr#
    #rr#
    .##.
""")


# --- at most 8 parameters ------------------------------------------------------------------

def public_entry_points() -> set[tuple[str, str]]:
    """(module file, function name) of every function of ``depixel.__all__``: the keyword
    entry points, which may take every option as a keyword (and build the object at once)."""
    found = set()
    for name in depixel.__all__:
        value = getattr(depixel, name)
        if inspect.isfunction(value):
            found.add((str(Path(inspect.getsourcefile(value)).relative_to(ROOT)), value.__name__))
    return found


def parameter_counts(path: Path) -> list[tuple[str, int]]:
    """(name, parameters) of every function and lambda in a source file; a method's ``self``
    or ``cls`` is not one (the caller does not pass it)."""
    counts = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            a = node.args
            n = len(a.posonlyargs) + len(a.args) + len(a.kwonlyargs) + (a.vararg is not None) + (a.kwarg is not None)
            first = (a.posonlyargs + a.args)[:1]
            n -= bool(first and first[0].arg in ("self", "cls"))
            counts.append((getattr(node, "name", "<lambda>"), n))
    return counts


def test_no_function_takes_more_than_8_parameters_but_the_public_keyword_entry_points():
    allowed = public_entry_points()
    assert ("depixel/api.py", "convert") in allowed and ("depixel/files/convert.py", "convert_file") in allowed
    over = [f"{path.relative_to(ROOT)}: {name} takes {n}"
            for path in sorted([*(ROOT / "depixel").rglob("*.py"), *(ROOT / "cli").rglob("*.py")])
            for name, n in parameter_counts(path)
            if n > MAX_PARAMETERS and (str(path.relative_to(ROOT)), name) not in allowed]
    assert not over, "pass a typed options object (depixel/options.py) instead: " + "; ".join(over)


def test_the_parameter_count_sees_every_kind_of_parameter(tmp_path):
    probe = tmp_path / "probe.py"
    probe.write_text("def f(a, /, b, *c, d, **e): pass\nclass C:\n    def m(self, a, b=1): pass\n"
                     "g = lambda x, y: x\n")
    assert parameter_counts(probe) == [("f", 5), ("m", 2), ("<lambda>", 2)]


# --- checked once, when made ---------------------------------------------------------------

@pytest.mark.parametrize("make, message", [
    (lambda: OutputOptions(stage="optimised"), "unknown stage 'optimised' (did you mean 'optimized'?)"),
    (lambda: OutputOptions(precision=13), "precision must be between 0 and 12, not 13"),
    (lambda: OutputOptions(scale=0), "scale must be a positive number, not 0"),
    (lambda: OutputOptions(width=64, height=32), "give width or height, not both"),
    (lambda: OutputOptions(width=6.5), "width must be an integer, not 6.5"),
    (lambda: OutputOptions(layout="tiled"), "unknown layout 'tiled'"),
    (lambda: OutputOptions(simplify=3), "simplify must be between 0 and 2, not 3"),
    (lambda: OutputOptions(shading="soft"), "unknown shading 'soft'"),
    (lambda: OutputOptions(animate="yes"), "animate must be True or False, not 'yes'"),
    (lambda: PrepareOptions(background="nocolour"), "unknown colour 'nocolour'"),
    (lambda: PrepareOptions(pixel_size="big"), "pixel_size must be auto, N or NxM"),
    (lambda: PrepareOptions(denoise="yes"), "denoise must be True, False or None, not 'yes'"),
    (lambda: PrepareOptions(transparent="#12"), "transparent: unknown colour '#12'"),
    (lambda: PrepareOptions(transparent_everywhere=1), "transparent_everywhere must be True or False, not 1"),
    (lambda: Limits(max_pixels=0), "max_pixels must be at least 1, not 0"),
    (lambda: ConvertOptions(params={"iterations": 3}), "params must be a depixel.Params, not dict"),
    (lambda: ConvertOptions.build(layout="cutout", precision=-1), "precision must be between 0 and 12, not -1"),
])
def test_a_bad_option_is_refused_when_the_object_is_made(make, message):
    with pytest.raises(ParameterError) as caught:
        make()
    assert str(caught.value).startswith(message), str(caught.value)


def test_options_are_kept_normalized_and_frozen():
    options = ConvertOptions.build(background="white", pixel_size="4x3", transparent="#f00", scale=2, width=64.0,
                                   simplify=0, denoise=False)
    assert options.prepare.background == (255, 255, 255) and options.prepare.pixel_size == (4, 3)
    assert options.prepare.transparent == (255, 0, 0) and options.prepare.denoise is False
    assert type(options.output.scale) is float and type(options.output.width) is int
    assert type(options.output.simplify) is float
    # two spellings of one option are one option, and one digest
    assert options == ConvertOptions.build(background=(255, 255, 255), pixel_size=(4, 3), transparent=(255, 0, 0),
                                           scale=2.0, width=64, simplify=0.0, denoise=False)
    with pytest.raises(dataclasses.FrozenInstanceError):
        options.output.scale = 3.0  # type: ignore[misc]
    with pytest.raises(ParameterError, match="precision"):  # a changed copy is checked again
        dataclasses.replace(options.output, precision=20)
    with pytest.raises(TypeError, match="unknown option 'colour'"):
        ConvertOptions.build(colour="red")


def test_depixelize_refuses_an_unknown_stage_as_every_entry_does():
    with pytest.raises(ParameterError) as caught:
        depixel.depixelize(SPRITE, stage="optimised")
    assert caught.value.parameter == "stage" and "did you mean 'optimized'?" in str(caught.value)


# --- the same keywords everywhere ----------------------------------------------------------

#: a valid value other than the default for every option field (a new field needs one here)
EXAMPLES = {"stage": "cells", "scale": 2.0, "width": 8, "height": 8, "precision": 3, "layout": "cutout",
            "simplify": 0.0, "shading": "flat", "background": (255, 0, 0), "pixel_size": (1, 1), "denoise": True,
            "transparent": (255, 255, 255), "transparent_everywhere": True, "max_pixels": 4096,
            "max_output_pixels": 65536, "max_frames": 3, "animate": True, "sheet": "16x16+1",
            "sheet_json": SheetJson("a.json", b'{"frames": {"a.png": {"frame": {"x": 0, "y": 0, "w": 2, "h": 2}}}}'),
            "tag": "walk"}
#: the options an example needs beside it (a tag plays an animation)
ALONG = {"tag": {"animate": True}}
#: options a keyword function has no use for: an SVG renders no PNG (a sheet's sprites count as frames)
NOT_TAKEN = {"convert": {"max_output_pixels"}, "convert_bytes": set(), "convert_file": set()}
OPTION_FIELDS = [item for part in (OutputOptions, PrepareOptions, Limits) for item in dataclasses.fields(part)]


def test_every_option_field_has_an_example():
    assert {item.name for item in OPTION_FIELDS} == set(EXAMPLES), "add the new field to EXAMPLES"


@pytest.mark.parametrize("function", ["convert", "convert_bytes", "convert_file"])
def test_every_keyword_function_takes_every_option_with_the_fields_default(function):
    parameters = inspect.signature(getattr(depixel, function)).parameters
    for item in OPTION_FIELDS:
        if item.name in NOT_TAKEN[function]:
            assert item.name not in parameters
            continue
        assert item.name in parameters, f"depixel.{function} does not take the option {item.name}"
        assert parameters[item.name].default == item.default, f"{function}({item.name}=...) has another default"
    prepare = inspect.signature(depixel.prepare_input).parameters
    assert all(item.name in prepare for item in dataclasses.fields(PrepareOptions))


@pytest.mark.parametrize("function", ["convert", "convert_bytes", "convert_file"])
def test_every_keyword_reaches_the_options_object(function, monkeypatch, tmp_path):
    made: list[ConvertOptions] = []

    def conversions(image, formats, options, **_):
        made.append(options)
        return {fmt: b"<svg/>" for fmt in formats}

    def convert_frames(source, targets, options, **_):
        made.append(options)
        return files.Written()

    monkeypatch.setattr(api, "conversions", conversions)
    monkeypatch.setattr(files, "convert_frames", convert_frames)
    call = {"convert": lambda **kw: depixel.convert(SPRITE, **kw),
            "convert_bytes": lambda **kw: depixel.convert_bytes(SPRITE, "svg", **kw),
            "convert_file": lambda **kw: depixel.convert_file(FIXTURES / "heart.png", tmp_path / "h.svg", **kw)}
    for item in OPTION_FIELDS:
        if item.name in NOT_TAKEN[function]:
            continue
        call[function](**{item.name: EXAMPLES[item.name]}, **ALONG.get(item.name, {}))
        part = next(p for p in (made[-1].output, made[-1].prepare, made[-1].limits)
                    if item.name in {f.name for f in dataclasses.fields(p)})
        assert getattr(part, item.name) == EXAMPLES[item.name], f"{function}({item.name}=...) did not reach it"


# --- the stamp digests every field ---------------------------------------------------------

@pytest.fixture
def fixed_version(monkeypatch):
    """Digests as of a fixed version string (the real one is part of every digest)."""
    monkeypatch.setattr(stamps, "__version__", "test")


#: digests of these options with the version "test", as the stamp of 769e19c (before the typed
#: options) computed them: the typed options changed none. Re-recorded once when Params gained
#: the straight runs (issue 46): Params are digested whole, so a new constant makes every output
#: made before stale (its bytes changed), while a new OutputOptions/PrepareOptions field is added()
RECORDED = [
    ("a.svg", {}, "a7e6abeeae598960"),
    ("a.png", {}, "e7d1742728841759"),
    ("a.pdf", {}, "e0e33f8636f93c2c"),
    ("a.png", {"shading": "flat"}, "a9472e17c46f1c44"),
    ("a.svg", {"transparent": "auto"}, "1d100cfe3f2e2043"),
    ("a.svg", {"transparent": "#fff", "transparent_everywhere": True}, "51bd52257ae4c054"),
    ("a.svg", {"scale": 2, "precision": 3, "layout": "cutout", "simplify": 0}, "b8c9c9947a30e11c"),
    ("a.svg", {"width": 64, "frame": 2, "background": "white", "pixel_size": "4x3", "denoise": True,
               "stage": "cells"}, "22d6024a65587c78"),
    ("a.svg", {"transparent_everywhere": True}, "a7e6abeeae598960"),  # without a colour: as the default
    ("a.svg", {"params": {"iterations": 2}}, "7b6933c7cd2676aa"),
]


@pytest.mark.parametrize("output, keywords, digest", RECORDED)
def test_stamps_written_before_the_typed_options_still_match(fixed_version, output, keywords, digest):
    keywords = dict(keywords)
    frame = keywords.pop("frame", 0)
    params = depixel.Params().replace(**keywords.pop("params", {}))
    assert files.file_target(output, ConvertOptions.build(params, **keywords), frame=frame).digest == digest


def digest_of(output: OutputOptions) -> str:
    return files.options_digest(ConvertOptions(output=output), "svg", 0)


def test_a_new_option_field_is_in_the_digest_without_being_named_there(fixed_version):
    @dataclasses.dataclass(frozen=True)
    class WithLabel(OutputOptions):
        label: str | None = None  # an option as the next issue adds it

    @dataclasses.dataclass(frozen=True)
    class WithGrain(OutputOptions):
        grain: int = added(0)  # one added after the stamp's format: left out while at its default

    default = digest_of(OutputOptions())
    assert digest_of(WithLabel(label="a")) != digest_of(WithLabel(label="b"))  # digested, never named
    assert digest_of(WithLabel()) != default  # a plain field is digested at its default too
    assert digest_of(WithGrain()) == default  # stamps written before it stay up to date
    assert digest_of(WithGrain(grain=2)) not in (default, digest_of(WithGrain(grain=3)))


def test_two_options_of_one_name_cannot_share_the_digest():
    names = [item.name for part in (OutputOptions, PrepareOptions) for item in dataclasses.fields(part)]
    assert len(names) == len(set(names)) and not {"fmt", "frame", "params", "version"} & set(names)


def test_the_command_line_builds_the_same_options_as_the_keywords():
    from depixel_cli.main import build_parser
    from depixel_cli.options import convert_options

    args = build_parser("convert").parse_args([
        "convert", "a.png", "--stage", "splines", "--width", "64", "--precision", "3", "--layout", "cutout",
        "--simplify", "0", "--shading", "flat", "--background", "white", "--pixel-size", "4", "--no-denoise",
        "--transparent", "auto", "--transparent-everywhere", "--max-pixels", "99", "--max-output-pixels", "98",
        "--max-frames", "7", "--iterations", "2", "--animate", "--tag", "walk"])
    assert convert_options(args) == ConvertOptions.build(
        depixel.Params().replace(iterations=2), stage="splines", width=64, precision=3, layout="cutout", simplify=0,
        shading="flat", background="white", pixel_size=4, denoise=False, transparent="auto",
        transparent_everywhere=True, max_pixels=99, max_output_pixels=98, max_frames=7, animate=True, tag="walk")
