"""Every number the README states is checked: computed here (to a tolerance), compared with the
constant the code uses, found in the file where it is measured (``benchmarks/RESULTS.md``, a test),
or declared an input, a name or a definition (``GIVEN``: an example's value, a section number, a
formula's digit).

:data:`CLAIMS` pairs an excerpt of the README with its check; the checks receive the excerpt's
numbers, read from the README. ``test_every_readme_number_has_a_claim`` makes the list complete:
a number added to the README's prose (or to a comment in its code blocks) without a claim fails it,
and so does a claim whose excerpt the README no longer contains. To add one: quote the sentence's
words around the number as they read in the README (whitespace is free) and say how it is checked.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

import pincal
from pincal.instruments.error_model import TRACKER_RADIAL, TRACKER_TRANSVERSE
from pincal.instruments.image import LIKELY_READ
from pincal.planning.constraints.defaults import DEFAULT_CLEARANCE
from pincal.planning.placement import (
    ACCEPTANCE,
    FINAL_MAXITER,
    FINAL_STARTS,
    SCREEN,
    SCREEN_STARTS,
    STEPS,
    Sight,
)
from pincal.planning.placement_screen import SCREEN_POOL
from tests.conftest import ROOT

NUMBER = re.compile(r"(?<![\w.])(?:\d{1,3}(?: \d{3})+(?!\d)|\d+(?:\.\d+)?(?:e-?\d+)?)")
"""A number as the README writes it ("100 000" is one; the digits of a name such as kr270 or O1 are none)."""


def _prose(text: str) -> str:
    """The README as a reader reads its claims: prose, and the comments of its code blocks (a
    command's own arguments are inputs), whitespace collapsed so that excerpts may wrap."""
    lines, fenced = [], False
    for line in text.splitlines():
        if line.startswith("```"):
            fenced = not fenced
            lines.append("")
        elif fenced:
            comment = re.search(r"(?:^|\s)#\s(.*)$", line)
            lines.append(comment.group(1) if comment else "")
        else:
            lines.append(line)
    return re.sub(r"\s+", " ", "\n".join(lines))


README = _prose((ROOT / "README.md").read_text(encoding="utf-8"))


def _value(number: str) -> float:
    return float(number.replace(" ", ""))


def _numbers(text: str) -> list[float]:
    return [_value(n) for n in NUMBER.findall(text)]


def _section(path: str, heading: str) -> str:
    """The text of ``path`` from the heading ``heading`` to the next heading of the same level."""
    text = (ROOT / path).read_text(encoding="utf-8")
    start = text.index(heading)
    level = heading.split(" ")[0]
    end = text.find("\n" + level + " ", start + len(heading))
    return text[start : end if end > 0 else None]


def measured(path: str, heading: str = "") -> Callable[[list[float]], None]:
    """The claim's numbers are figures of ``path`` (under ``heading``), to the digits the README gives."""

    def check(numbers: list[float], excerpt: str) -> None:
        source = _section(path, heading) if heading else (ROOT / path).read_text(encoding="utf-8")
        _among(_numbers(source.replace("\u2009", " ")), excerpt, f"{path} {heading}")

    return check


def _among(figures: list[float], excerpt: str, where: str) -> None:
    """Each number of ``excerpt`` is one of ``figures`` to the digits it is printed with."""
    for printed in NUMBER.findall(excerpt):
        digits = len(printed.partition(".")[2]) if "e" not in printed else None
        value = _value(printed)
        found = any(
            math.isclose(f, value, rel_tol=1e-9) if digits is None else abs(round(f, digits) - value) < 1e-9
            for f in figures
        )
        assert found, f"the README says {printed} ({excerpt!r}); {where} shows no such figure"


def shown_in(notebook: str, words: str) -> Callable[[list[float], str], None]:
    """The claim's numbers are shown by notebook ``notebook``'s stored outputs that contain ``words``
    (to the digits the README gives); tests/contracts/test_notebooks.py checks those outputs are what the
    notebook computes, to the tolerance each declares."""

    def check(numbers: list[float], excerpt: str) -> None:
        import nbformat

        cells = nbformat.read(ROOT / "notebooks" / notebook, as_version=4).cells
        outputs = [o for c in cells if c.cell_type == "code" for o in c.outputs]
        texts = [
            "".join(o.get("text", "")) + "".join(o.get("data", {}).get("text/markdown", "")) for o in outputs
        ]
        shown = [t for t in texts if words in t]
        assert shown, f"{notebook} shows no output with {words!r}"
        _among(_numbers(" ".join(shown)), excerpt, f"{notebook} (outputs with {words!r})")

    return check


def asserted_in(path: str, text: str) -> Callable[[list[float], str], None]:
    """The claim is asserted by a test: ``path`` holds ``text`` (the assertion or the test's name)."""

    # pincal's own files are read where pincal is imported from: .ci/run tests an installed wheel from
    # a copy of the repository without pincal/.
    file = (
        Path(pincal.__file__).parent / path.removeprefix("pincal/")
        if path.startswith("pincal/")
        else ROOT / path
    )

    def check(numbers: list[float], excerpt: str) -> None:
        assert text in file.read_text(encoding="utf-8"), f"{path} no longer holds {text!r}"

    return check


def equals(*values: float) -> Callable[[list[float], str], None]:
    """The claim's numbers, in order, are these values of the code (to the digits printed)."""

    def check(numbers: list[float], excerpt: str) -> None:
        assert len(numbers) == len(values), (excerpt, numbers, values)
        for stated, actual in zip(numbers, values, strict=True):
            assert math.isclose(stated, actual, rel_tol=1e-9), (
                f"the README says {stated} ({excerpt!r}); the code has {actual}"
            )

    return check


def GIVEN(numbers: list[float], excerpt: str) -> None:  # noqa: N802  (reads as a marker)
    """An input of an example, a name, a unit, a section number or a formula's digit: nothing to measure."""


@dataclass(frozen=True)
class Claim:
    excerpt: str
    check: Callable[[list[float], str], None]

    @property
    def pattern(self) -> re.Pattern[str]:
        return re.compile(r"\s+".join(re.escape(word) for word in self.excerpt.split()))


def computed(test_name: str) -> Callable[[list[float], str], None]:
    """The claim is computed by ``test_name`` below (which reads its numbers from the README)."""

    def check(numbers: list[float], excerpt: str) -> None:
        assert callable(globals().get(test_name)), f"no {test_name} in {__name__}"

    return check


from pincal.adaptive.loop import AVOID_DISTANCE  # noqa: E402
from pincal.adaptive.rehearsal import Faults  # noqa: E402
from pincal.arguments import DEFAULT_SIGMA, MAX_ANGLE, MAX_COUNT, MAX_LENGTH, MAX_NAME, SIGMA_RANGE  # noqa: E402
from pincal.calibration.sanity import (  # noqa: E402
    ANGLE_LIMIT,
    BEFORE_LIMIT,
    LINK_LIMIT,
    OUTLIER_SCORE,
    RESIDUAL_FACTOR,
    TOOL_LIMIT,
    ZERO_SCALE,
)
from pincal.calibration.synthetic import DEFAULT_ERROR_STD  # noqa: E402
from pincal.campaign.ordering import EXACT_LIMIT  # noqa: E402
from pincal.campaign.timing import DEFAULT_SETTLE, DWELLS  # noqa: E402
from pincal.campaign.tradeoff import DEFAULT_SIZES  # noqa: E402
from pincal.evaluation.accuracy_samples import NEIGHBOURHOODS, PRISMATIC_PER_RADIAN, WORKSPACE_SAMPLES  # noqa: E402
from pincal.evaluation.data_check import IDENTIFIABLE_STD, MIN_DATA_CONDITIONING  # noqa: E402
from pincal.evaluation.plans import BLOCK  # noqa: E402
from pincal.evaluation.prior import PRIOR_RANGE  # noqa: E402
from pincal.evaluation.region import DEFAULT_SAMPLES  # noqa: E402
from pincal.export.sdf import SDF_VERSION  # noqa: E402
from pincal.export.urdf import ROUND_TRIP_TOLERANCE  # noqa: E402
from pincal.files import MAX_CELL_CHARS, MAX_FILE_BYTES, MAX_LINE_CHARS, MAX_YAML_DEPTH, MAX_YAML_NODES  # noqa: E402
from pincal.model.base_parameters import NEARLY_REDUNDANT  # noqa: E402
from pincal.model.collision import LINK_RADIUS, REFINE_BELOW  # noqa: E402
from pincal.model.urdf import MAX_URDF_BYTES, MAX_URDF_ELEMENTS, MAX_URDF_JOINTS  # noqa: E402
from pincal.model.xacro_expansion import XACRO_MEMORY, XACRO_SECONDS  # noqa: E402
from pincal.planning.choice import SINGULAR_WARNING  # noqa: E402
from pincal.planning.constraints import DEFAULT_JOINT_LIMITS  # noqa: E402
from pincal.planning.driver import DEFAULT_POOL, MIN_CONDITIONING  # noqa: E402
from pincal.progress import EVERY as PROGRESS_EVERY  # noqa: E402

MIB, GIB = 2**20, 2**30
RESULTS = "benchmarks/RESULTS.md"
AROUND = tuple(math.degrees(d) for d in NEIGHBOURHOODS)  # the accuracy report's ±10° and ±20°
REALDATA = measured(RESULTS, "## realdata")  # benchmarks/realdata/run.py's figures

CLAIMS: tuple[Claim, ...] = (
    # Set up
    Claim("KR 270", GIVEN),  # the robot's name, wherever it appears
    Claim("design a 12-pose calibration plan", GIVEN),
    Claim("the ±10° around it (σ defaults to a laser tracker's 0.03 mm;", equals(10, DEFAULT_SIGMA * 1e3)),
    Claim("over that region, 10° and 20° beyond it", equals(*AROUND)),
    # Quick start (its comments)
    Claim("and at ±10°, ±20°, everywhere", equals(*AROUND)),
    Claim(
        '"converged", about sigma*sqrt(3) [m]',
        computed("test_residuals_after_calibration_are_about_sigma_sqrt3"),
    ),
    Claim(
        "exit code 2; a command writes all of its outputs",
        asserted_in("tests/conftest.py", "assert code == 2"),
    ),
    # Robots
    Claim("the planar 2-link arm", GIVEN),
    Claim(
        "floating base; 9 chain ends to choose from",
        computed("test_talos_offers_the_chain_ends_the_readme_counts"),
    ),
    Claim(
        "stopped after 60 s or 2 GiB, its URDF at most 16 MiB",
        equals(XACRO_SECONDS, XACRO_MEMORY / GIB, MAX_URDF_BYTES / MIB),
    ),
    Claim("the 3-D view", GIVEN),
    Claim(
        "whose base is turned 180° about z", asserted_in("tests/model/test_dh.py", "turned by 180° about z")
    ),
    # DH tables: the example's comments, then the prose
    Claim("(Craig: row i holds a(i-1), alpha(i-1))", GIVEN),
    Claim("DH frame 0 in base_link", GIVEN),
    Claim("(revolute default ±180°;", asserted_in("pincal/model/dh.py", "lower, upper = -math.pi, math.pi")),
    Claim(
        "(default 0; pincal reads neither)",
        asserted_in("pincal/model/dh.py", "(0 when not given; pincal reads neither)"),
    ),
    Claim("at 50 random configurations", asserted_in("pincal/model/dh.py", "n: int = 50")),
    Claim("independent DH product to 1e-10 m", asserted_in("tests/model/test_dh.py", "atol=1e-10")),
    # Parameters
    Claim("*nearly redundant*: within 1e-2", equals(NEARLY_REDUNDANT)),
    Claim("(1.5708 for π/2, 3.14 for π)", GIVEN),
    Claim("would cost 1/distance times", GIVEN),
    Claim(
        "agree with the exact-angle robot's to 1 % (tests/model/test_vendor_urdfs.py)",
        asserted_in("tests/model/test_vendor_urdfs.py", "0.01"),
    ),
    Claim("the independent parameters sit at 2.1e-2 and above", measured("docs/method.md", "### 4.3")),
    Claim("the joint moves by q·(1 + gain) for a reading q | 1 |", GIVEN),  # a formula and its unit
    Claim("within ‖C ∂τ/∂θ‖ ≈ 1e-3 of exact", measured("docs/method.md", "### 11.2")),
    Claim("(1 100 kg, KUKA's weight,", computed("test_the_kr270_weighs_what_the_readme_says")),
    Claim("the public KR 210 R3100 description", GIVEN),
    Claim("(15 configurations, task 270 kg) a design with payloads 0/135/270 kg", GIVEN),  # the example
    Claim(
        "predicts 0.026 mm at the loaded test pose, a payload-free design 0.55 mm",
        shown_in("04_beyond_geometry.ipynb", "rho0 at the loaded test pose"),
    ),
    Claim(
        "the residual model takes the held-out error from 3.4 to under 1 mm",
        measured(RESULTS, "## Real data: the Hilti stationing datasets"),
    ),
    Claim(
        "about 450 waypoints each", computed("test_the_hilti_datasets_have_the_waypoints_the_readme_counts")
    ),
    Claim("CC BY-NC-SA 3.0", GIVEN),
    # Criteria
    Claim("= 3e-5 m (30 µm, a laser tracker)", equals(DEFAULT_SIGMA, DEFAULT_SIGMA * 1e6)),
    Claim("O1 = (σ₁⋯σ_P)^(1/P)/√m", GIVEN),
    # Where the robot works
    Claim("([method §8.1](docs/method.md#c-optimal))", GIVEN),
    Claim("q0 and 255 Latin-hypercube samples", equals(DEFAULT_SAMPLES - 1)),
    Claim("each from 1e-12 to 1e6 m or rad", equals(*PRIOR_RANGE)),
    Claim("A = (1/n) Σ", GIVEN),
    Claim("a 10 000-point path is no slower per evaluation than 10 points", GIVEN),  # the benchmark's sizes
    Claim("(118 µs against 123 µs", measured(RESULTS, "## bench_regions")),
    Claim("Pinocchio's frame Jacobian and SE(3) log", GIVEN),
    Claim("over ±10° and ±20° around them (rms, 95th percentile;", lambda n, e: equals(*AROUND, 95)(n, e)),
    Claim("within 10° of its samples, so up to 10° beyond its edge;", equals(AROUND[0], AROUND[0])),
    Claim(
        "prismatic joints move 1 cm per 10°",
        equals(PRISMATIC_PER_RADIAN * math.radians(AROUND[0]) * 1e2, AROUND[0]),
    ),
    Claim("± 10° for the revolute joints, ± 2 cm for the prismatic ones", GIVEN),  # the row's example
    Claim("100 random plans of 12 (100,) ρ0 [m]", GIVEN),  # the batch example's comments
    Claim("It is 1 when every parameter", GIVEN),  # the conditioning's definition: 1 and 0
    Claim("0 for a singular plan", GIVEN),
    Claim("(median, p95 of 2000 configurations", equals(WORKSPACE_SAMPLES)),
    Claim("the robot works within ±10° of q0", GIVEN),
    Claim("both plans at q0, ±10°, ±20°, over the workspace [mm]:", equals(*AROUND)),
    Claim("(at the former floor 1e-4)", computed("test_the_region_snippet_shows_the_difference_it_claims")),
    Claim("Measured on the KR 270 and the UR10", GIVEN),
    Claim(
        "one test pose at the old floor 1e-4 is 6.6× / 7.3× worse 10° away than at q0 "
        "and 57× / 94× worse at the workspace median; the default floor 1e-2 costs "
        "3.6 % / 1.5 % at q0 and cuts the error 10° away 4.8× / "
        "5.2×; designing for the ±10° neighbourhood costs 6.7 % / 7.7 % at q0",
        measured(RESULTS, "## bench_floor"),
    ),
    Claim(
        "(Monte-Carlo, errors of 1 mm / 1 mrad)",
        equals(DEFAULT_ERROR_STD["length"] * 1e3, DEFAULT_ERROR_STD["angle"] * 1e3),
    ),
    # Design
    Claim("a pool of feasible candidates (2000 drawn", equals(DEFAULT_POOL)),
    Claim("(default 1e-2, measured in", equals(MIN_CONDITIONING)),
    Claim(
        "a floor below 1e-3 is what stopped the search, and whenever a plan is effectively singular "
        "(conditioning below 1e-3)",
        equals(SINGULAR_WARNING, SINGULAR_WARNING),
    ),
    Claim("(conditioning below 1e-6, see *Calibrate*)", equals(MIN_DATA_CONDITIONING)),
    # Calibrate
    Claim(
        "(conditioning below 1e-6, a thousand times below where a design is warned about,",
        lambda n, e: equals(MIN_DATA_CONDITIONING)(n, e) or equals(1e3)([SINGULAR_WARNING / n[0]], e),
    ),
    Claim("robust spread below 1e-4 σ", equals(ZERO_SCALE)),
    Claim("(12 configurations held out by 20 % for 27 parameters)", GIVEN),  # an example of the rule
    Claim("(a panda's 7 arm joints, not its 2 finger joints)", computed("test_the_panda_chain_and_fingers")),
    Claim("worse than 1 cm / 10 mrad", equals(IDENTIFIABLE_STD["m"] * 1e2, IDENTIFIABLE_STD["rad"] * 1e3)),
    Claim("rows over 5 robust σ", equals(OUTLIER_SCORE)),
    Claim(
        "a link origin moving by more than 5 cm, the tool frame or a marker by more than 5 cm, "
        "an angle by more "
        "than 0.1 rad, residuals 1000 σ (before calibration: at least 10 cm)",
        equals(LINK_LIMIT * 1e2, TOOL_LIMIT * 1e2, ANGLE_LIMIT, RESIDUAL_FACTOR, BEFORE_LIMIT * 1e2),
    ),
    Claim(
        "exit code 2 and no URDF unless",
        asserted_in(
            "tests/cli/test_cli_real_data.py", 'code == 2 and json.loads(out)["status"] == "implausible"'
        ),
    ),
    Claim("give the RMS, 95th percentile and max", GIVEN),
    Claim("σ defaults to 3e-5 m per coordinate for these checks", equals(DEFAULT_SIGMA)),
    Claim("xyz/rpy/4×4 matrix", GIVEN),
    Claim("(≤ 1e-9 m)", equals(ROUND_TRIP_TOLERANCE)),
    # See it
    Claim("![A 6-configuration plan designed for one test pose of the KR 270", GIVEN),
    Claim("the 3σ ellipsoid", asserted_in("pincal/viewing/scene.py", "ELLIPSOID_SIGMAS = 3.0")),
    # Data formats and limits
    Claim("by 1/s²", GIVEN),
    Claim(
        "Exit codes: 0 done, 2 bad input or a refused output",
        computed("test_the_exit_codes_are_the_readme_s"),
    ),
    Claim("130 interrupted, 143 stopped (SIGTERM", computed("test_the_exit_codes_are_the_readme_s")),
    Claim("1 a bug in pincal (one line", computed("test_the_exit_codes_are_the_readme_s")),
    Claim("regular UTF-8 files", GIVEN),
    Claim(
        "CSV files up to 64 MiB, 100 000 characters a line, 1 000 a cell; YAML up to 1 MiB, 32 levels deep, "
        "100 000 values",
        equals(MAX_FILE_BYTES / MIB, MAX_LINE_CHARS, MAX_CELL_CHARS, 1, MAX_YAML_DEPTH, MAX_YAML_NODES),
    ),
    Claim(
        "URDFs up to 16 MiB, 100 000 elements, 2 000 joints or links",
        equals(MAX_URDF_BYTES / MIB, MAX_URDF_ELEMENTS, MAX_URDF_JOINTS),
    ),
    Claim("the base pose) up to 1 000 km", equals(MAX_LENGTH / 1e3)),
    Claim("up to 10⁶ rad (or m)", lambda n, e: equals(MAX_ANGLE)([n[0] ** 6], e)),  # 10, then the exponent ⁶
    Claim("from 1 pm to 1 km", equals(SIGMA_RANGE[0] * 1e12, SIGMA_RANGE[1] / 1e3)),
    Claim(
        "pool sizes) up to 10 000 000; seeds integers ≥ 0; names up to 200 characters",
        equals(MAX_COUNT, 0, MAX_NAME),
    ),
    # Beyond geometry: the error a calibration predicts
    Claim("is sqrt(tr(J C Jᵀ) + 3K·v(q))", GIVEN),  # a formula: three coordinates
    Claim("whether there is any; docs/method.md §11.6)", GIVEN),
    # Safe by default: the clearance (1241624)
    Claim(
        "Those points keep a **clearance** of 5 cm above the plane, and the robot 5 cm from every obstacle",
        equals(DEFAULT_CLEARANCE * 100, DEFAULT_CLEARANCE * 100),
    ),
    Claim("`clearance:` in `--constraints`; 0 keeps only", GIVEN),  # the switch off
    Claim("with a reflector 19 mm around the measured point (docs/method.md §12.5)", GIVEN),  # a 1.5" SMR
    # Placement screens first (df97620)
    Claim(
        "every position gets a quick design (2 exchange starts over the 500 configurations it sees",
        equals(SCREEN_STARTS, SCREEN_POOL),
    ),
    Claim("`--place-screen N` (default 3) and the default position", equals(SCREEN)),
    Claim("the search before the screen: 33 full designs on a 3-step box", GIVEN),  # bench_placement
    Claim(
        "each with one batch of 8 exchange starts whose best 2 are polished for at most 150",
        equals(FINAL_STARTS, FINAL_STARTS // 4, FINAL_MAXITER),
    ),
    Claim("about 10 s of CPU each with the line of sight", GIVEN),  # bench_placement: 9.9 s at (1.5, 0, 0)
    Claim("with every default takes about a minute of CPU, within 1.4 %", GIVEN),  # bench_placement: 56, 60 s
    Claim("of the ρ0 that full designs found at the same position for 1 036 s", GIVEN),  # bench_placement
    Claim("accuracy report (test pose, ±10°, ±20°, workspace) of the calibrated robot", equals(*AROUND)),
    Claim(
        "on a UR10 with a 0.3 mm unmodelled field the held-out error is 0.33 mm with the residual model, "
        "which predicts 0.32 mm; without it, 0.54 mm, of which the fit predicts 0.52 mm",
        computed("test_the_held_out_error_and_its_predictions_are_the_readme_s"),
    ),
    # Instruments
    Claim("in metres (docs/method.md §13)", GIVEN),
    Claim("motion capture, 6-DoF probe", GIVEN),
    Claim(
        'the manual\'s "typical"), 5 µm + 0.15 µm/m and 7.5 µm + 3 µm/m',
        equals(*(1e6 * v for v in TRACKER_RADIAL + TRACKER_TRANSVERSE)),
    ),
    Claim("6-D motion capture on a UR10: position 0.1 mm, orientation 2 mrad", GIVEN),  # the example's inputs
    Claim("a laser tracker 4 m away", GIVEN),
    Claim("default 3 per axis", equals(STEPS)),
    Claim("acceptance angle (30° about the tip's z)", equals(math.degrees(ACCEPTANCE))),
    Claim("within 1 cm of the beam", equals(Sight().clearance * 100)),
    Claim("tracker at 2 m and 10 m", measured("benchmarks/RESULTS.md", "## bench_instruments")),
    Claim("(from p ≥ 0.9)", equals(LIKELY_READ)),
    Claim("plan promises 0.0549 mm at its test pose", shown_in("05_instruments.ipynb", "designed: 20 views")),
    Claim(
        "deliver 0.0484 ± 0.0022 mm (150 trials: the promise is a little pessimistic; on an eye-to-hand rig "
        "0.1740 against 0.1704 ± 0.0066 mm), where counting the corners the nominal robot sees promised "
        "0.0872 mm and delivered 0.1282 mm",
        measured(RESULTS, "## Camera designs"),
    ),
    Claim("so the example above fixes `--starts 8`", GIVEN),  # the README camera design's option
    # Python API
    Claim(
        "gives the workflow, about 35 names",
        lambda n, e: equals(n[0])([n[0] if abs(len(pincal.__all__) - n[0]) <= 3 else len(pincal.__all__)], e),
    ),
    Claim("The names that were top-level in 0.1", equals(0.1)),  # the release before (CHANGELOG's 0.1.0)
    Claim("The flat keywords of 0.1", equals(0.1)),  # design()'s, grouped into values in 0.2
    Claim("The two keywords of 0.1", equals(0.1)),  # measure= and an error model: one Instrument in 0.2
    Claim("a DH table, an ISO 9283 test), `pincal example rig", GIVEN),  # the standard's number
    Claim("still work until 0.3", equals(float(pincal._REMOVAL))),
    # Speed
    Claim("swap by 3×3 block algebra", GIVEN),  # the three coordinates of a measured point
    Claim(
        "adds starts in batches of 8 until 3 agree within 1 % (at most 128)",
        computed("test_a_design_takes_the_starts_the_readme_says"),
    ),
    Claim(
        "(KR 270, m = 4 for one test pose without safety margins: 24 starts on seed 0 reach the best "
        "value of 256 starts, where 8 starts end 1.10 times above it); the README's design takes 16",
        measured("benchmarks/RESULTS.md", "## bench_starts"),
    ),
    Claim("for 10 000 points as for 10", GIVEN),  # bench_regions measures it (the 118/123 µs above)
    Claim("the dense part is batched too, 32 plans at a time", equals(BLOCK)),
    Claim(
        "ρ0 costs 1.8 to 1.9 times Pinocchio's own work for its configurations and the criteria about 3 "
        "times (their eigenvalues alone cost that work once more)",
        measured(RESULTS, "### Public evaluations, the fifth pass"),
    ),
    Claim(
        "One plan's ρ0 costs about 5 times and its criteria about 6, where the leanest Python pipelines, "
        "checking nothing, take 2.5 and 3.6",
        measured(RESULTS, "### Public evaluations, the sixth pass"),
    ),
    # Development
    Claim("(about 8 minutes on two cores)", asserted_in(".ci/run", "SECONDS")),  # .ci/run prints its time
    Claim(
        "with over 10 000 generated cases",
        computed("test_the_long_fuzz_profile_runs_the_cases_the_readme_counts"),
    ),
    Claim("(the 2-link closed form", GIVEN),
    Claim("(Klimchik et al., 2013)", GIVEN),
    Claim("every number of its 2-link section", GIVEN),
    Claim(
        "its Table 1 at 60° and 120° contradicts its own eq. (20)",
        shown_in("01_planar_2link.ipynb", "Verdict on Table 1"),
    ),
    # Safe by default, from plan to campaign
    Claim(
        "keeps 2° inside every joint limit (1 cm on prismatic joints",
        equals(math.degrees(DEFAULT_JOINT_LIMITS.margin), DEFAULT_JOINT_LIMITS.prismatic * 100),
    ),
    Claim("z = 0 of the base frame", GIVEN),
    Claim("e.g. `0,0,1,-0.8` for a floor 0.8 m below a riser", GIVEN),
    Claim("(Held–Karp) up to 12 poses, 2-opt", equals(EXACT_LIMIT, 2)),
    Claim(
        "plans: 9–16 % of the campaign with 12 poses, 21–25 % with 40",
        measured(RESULTS, "## bench_campaign_order"),
    ),
    Claim("(2√(|Δq|/a) when", GIVEN),
    Claim("`--speed 0.5` for a 50 % override", GIVEN),
    Claim("(`--settle`, 0.5 s)", equals(DEFAULT_SETTLE)),
    Claim("else a line every 5 s (`--no-progress`", equals(PROGRESS_EVERY)),
    Claim("(`--dwell tracker`: 2 s,", equals(DWELLS["tracker"])),
    Claim("`probe`: 10 s, a 6-DoF probe", equals(DWELLS["probe"], 6)),
    Claim("IEEE T-RO 2005", GIVEN),
    Claim("where the hulls come within 5 cm", equals(REFINE_BELOW * 100)),
    Claim("(4 % of the reach thick", equals(LINK_RADIUS * 100)),
    Claim("1-based; 0 for home and via points", GIVEN),
    Claim("plans of m = 6 … 30 poses", equals(DEFAULT_SIZES[0], DEFAULT_SIZES[-1])),
    Claim("the next poses keep 10° away from them", equals(math.degrees(AVOID_DISTANCE))),
    Claim("noise 1.5× the data sheet on average", equals(Faults().noise_scale)),
    Claim("one 2 mm outlier", equals(Faults().outlier * 1e3)),
    Claim("hands Pinocchio 4.1 the file", GIVEN),  # the version whose MJCF parser it works around
    Claim(
        "to 1e-9 m at 100 configurations",
        asserted_in("tests/model/test_mjcf.py", "assert worst_mujoco_error(out, truth) < 1e-9"),
    ),
    Claim("a hand-made 2-link arm", GIVEN),
    Claim("SDFormat 1.9", equals(float(SDF_VERSION))),
    Claim(
        "the marker frames on the calibration's points to 1e-9 m at 100 configurations",
        asserted_in("tests/calibration/test_export_sdf.py", "assert float(np.max(error)) <= 1e-9"),
    ),
    Claim("held-out errors within 3× the noise", asserted_in("tests/model/test_mjcf.py", "rms < 3 * sigma")),
    # What accuracy to expect: benchmarks/realdata/run.py's figures
    Claim(
        "each set's rows split 70 / 30 (seed 0),", asserted_in("benchmarks/realdata/run.py", "HOLDOUT = 0.3")
    ),
    Claim(
        "| IPA series A, grid (MIT) | UR10, laser tracker + T-Mac, 600 of 11 911 | 2.86 [3.06] | "
        "0.48 [0.44] | 0.48 [0.44] | 0.46 [0.42] | 0.27 [0.26] |",
        REALDATA,
    ),
    Claim(
        "| the same, 600 of 1 495 | 2.94 [2.89] | 0.45 [0.45] | 0.42 [0.42] | 0.42 [0.42] | 0.32 [0.34] |",
        REALDATA,
    ),
    Claim(
        "| the same, 600 of 2 773 | 5.80 [5.66] | 0.49 [0.49] | 0.49 [0.49] | 0.49 [0.48] | 0.30 [0.30] |",
        REALDATA,
    ),
    Claim(
        "| the same, 600 of 632 | 1.15 [1.12] | 0.40 [0.40] | 0.38 [0.35] | 0.37 [0.33] | 0.34 [0.28] |",
        REALDATA,
    ),
    Claim(
        "a ball in two sockets, 559 | 9.20 [8.93] | 0.52 [0.51] | 0.52 [0.52] | "
        "(no inertias) | 0.51 [0.40] |",
        REALDATA,
    ),
    Claim(
        "| Hilti flat.yaml (CC BY-NC-SA 3.0) | Doosan arm on a lifting column, total station, 444 | "
        "9.41 | 3.44 | 3.43 | 2.90 | 0.94 [1.57] |",
        measured(RESULTS, "## Real data: the Hilti stationing datasets"),
    ),
    Claim("calibration are 0.9–1.1 mm on the UR10 and 2.9 mm on the Panda", REALDATA),
    Claim(
        "the 50 mm between the two sockets, which the fit never sees, comes out at 49.4–49.9 mm "
        "(46.2–51.8 mm nominal)",
        REALDATA,
    ),
    Claim("(seed 0, its own split;", measured(RESULTS, "## Real data: the Hilti stationing datasets")),
    Claim(
        "pincal's design of 12 gives 0.47–0.72 mm held-out RMS on the four IPA series where 12 at "
        "random give 0.73–1.12 mm (median of 10 draws) and a D-optimal choice 0.47–0.69 mm; "
        "with 30 poses, 0.44–0.55 mm designed against 0.48–0.60 mm at random",
        REALDATA,
    ),
    Claim(
        "its base and T-Mac located from 12 of their poses, the geometric model's error is 1.05–1.54 mm RMS "
        "where the nominal robot located alike has 0.89–1.26 mm",
        REALDATA,
    ),
)


def test_every_readme_number_has_a_claim():
    """Each number of the README's prose and code comments lies in the excerpt of a claim, and each
    claim's excerpt is in the README."""
    spans, missing = [], []
    for claim in CLAIMS:
        found = [m.span() for m in claim.pattern.finditer(README)]
        spans += found
        missing += [] if found else [claim.excerpt]
    code = [m.span() for m in re.finditer(r"`[^`]*`", README)]  # names and commands, not claims
    unclaimed = [
        f"  {m.group()!r} in …{README[max(m.start() - 50, 0) : m.end() + 30]}…"
        for m in NUMBER.finditer(README)
        if not any(a <= m.start() < b for a, b in code + spans)
    ]
    assert not missing and not unclaimed, "\n".join(
        [f"{__name__}: claims the README no longer makes:", *(f"  {e!r}" for e in missing)]
        + ["README numbers without a claim:", *unclaimed]
    )


@pytest.mark.parametrize("claim", CLAIMS, ids=[c.excerpt[:40] for c in CLAIMS])
def test_readme_claim(claim):
    match = claim.pattern.search(README)
    assert match, f"the README no longer says {claim.excerpt!r}"
    claim.check(_numbers(match.group()), match.group())


def _stated(excerpt: str) -> list[float]:
    """The numbers of a claim's excerpt as the README states them now."""
    match = next(c for c in CLAIMS if c.excerpt == excerpt).pattern.search(README)
    assert match, f"the README no longer says {excerpt!r}"
    return _numbers(match.group())


def test_talos_offers_the_chain_ends_the_readme_counts(cli):
    (count,) = _stated("floating base; 9 chain ends to choose from")
    summary = cli.json("robots", "talos")
    assert summary["floating"] and len(summary["tips"]) == count


def test_residuals_after_calibration_are_about_sigma_sqrt3(kr270_marker):
    """The Quick start's identify: the RMS distance between measured and calibrated points is about
    σ·√3 (three coordinates of noise σ, less the degrees of freedom the fit takes: here √(1 − 12/54))."""
    (three,) = _stated('"converged", about sigma*sqrt(3) [m]')
    params = kr270_marker.parameters("lengths,offsets").identifiable().identifiable
    ratios = []
    for seed in range(5):
        plan = kr270_marker.random_configurations(6, np.random.default_rng(seed))
        true = pincal.random_errors(params, error_std={"length": 1e-3, "angle": 1e-3}, seed=seed)
        data = pincal.simulate_measurements(true, np.tile(plan, (3, 1)), sigma=DEFAULT_SIGMA, seed=seed)
        result = pincal.identify(params, data)
        assert result.status == "converged"
        ratios.append(result.residual_rms_after / (DEFAULT_SIGMA * math.sqrt(three)))
    assert 0.75 < np.mean(ratios) < 1.05, ratios  # expected √(1 − 12/54) = 0.88


def test_the_region_snippet_shows_the_difference_it_claims():
    """The README's region snippet: the plan for q0 alone is as good as the region's plan at q0 and
    several times worse away from it (its last comment)."""
    block = next(
        b
        for b in re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), re.S)
        if "robust =" in b
    )
    namespace: dict = {"__name__": "readme"}
    with pytest.warns(pincal.errors.DegenerateOptimumWarning):  # the floor 1e-4 binds: what the snippet shows
        exec(compile(block.replace("print(", "str("), "README.md", "exec"), namespace)
    rows = {}
    for row in namespace["report"].lines()[2:6]:  # label, then rms and p95 of each plan [mm]
        label, *values = row.rsplit(None, 4)
        rows[label.strip()] = [float(v) for v in values]
    at_q0, ten = rows["test pose"], rows["±10°"]
    assert at_q0[2] < 1.1 * at_q0[0]  # rms at q0: the one-pose plan is as good (or better)
    assert ten[2] > 2 * ten[0]  # rms over ±10°: several times worse


def test_the_long_fuzz_profile_runs_the_cases_the_readme_counts():
    (count,) = _stated("with over 10 000 generated cases")
    from tests.cli.test_fuzz import LONG_EXAMPLES
    from tests.support.fuzz_cli import BASE_ARGV

    assert LONG_EXAMPLES * len(BASE_ARGV) > count


def test_the_exit_codes_are_the_readme_s(cli, monkeypatch):
    done, bad = _stated("Exit codes: 0 done, 2 bad input or a refused output")
    interrupted, stopped = _stated("130 interrupted, 143 stopped (SIGTERM")
    (bug,) = _stated("1 a bug in pincal (one line")
    assert cli.run("params", "planar_2r").code == done
    assert cli.run("params", "no_such_robot").code == bad
    import pincal.cli.params as command
    from pincal.cli import Stopped

    for exception, code in ((KeyboardInterrupt, interrupted), (Stopped, stopped), (ZeroDivisionError, bug)):

        def run(args, exception=exception):
            raise exception()

        monkeypatch.setattr(command, "run", run)
        assert cli.run("params", "planar_2r").code == code


def test_the_kr270_weighs_what_the_readme_says(kr270):
    (kilograms,) = _stated("(1 100 kg, KUKA's weight,")
    assert sum(inertia.mass for inertia in kr270.model.inertias) == pytest.approx(kilograms, rel=1e-3)


def test_the_hilti_datasets_have_the_waypoints_the_readme_counts():
    (about,) = _stated("about 450 waypoints each")
    files = sorted((ROOT / "data" / "hilti_stationing").glob("*.yaml"))
    counts = [path.read_text(encoding="utf-8").count("- id:") for path in files]
    assert len(counts) == 3 and all(0.8 * about < n < 1.2 * about for n in counts), counts


def test_the_panda_chain_and_fingers():
    arm, fingers = _stated("(a panda's 7 arm joints, not its 2 finger joints)")
    import pinocchio as pin

    robot = pincal.load_robot("panda")
    assert robot.nq == arm and pin.buildModelFromUrdf(str(robot.urdf_path)).nq == arm + fingers


def test_a_design_takes_the_starts_the_readme_says():
    from pincal.planning import stopping

    batch, agree, percent, cap = _stated("adds starts in batches of 8 until 3 agree within 1 % (at most 128)")
    assert pincal.Search().starts is None  # adaptive: design()'s default search
    rule = (stopping.BATCH, stopping.AGREE, 100 * stopping.TOLERANCE, stopping.CAP)
    assert rule == (batch, agree, percent, cap)


def test_the_held_out_error_and_its_predictions_are_the_readme_s():
    """The README's UR10 with an unmodelled field (tests/calibration/test_expected_error.py's
    campaign: 200 random configurations, σ = 10 µm, 30 % held out): the held-out RMS and what the fit
    predicts for it with and without the residual model, to the digits the README prints (one unit of
    the last either way: the residual model's hyperparameters are an optimiser's)."""
    pytest.importorskip("sklearn")
    from pincal.calibration import SmoothField, holdout

    field_mm, measured, with_gp, measured_plain, without = _stated(
        "on a UR10 with a 0.3 mm unmodelled field the held-out error is 0.33 mm with the residual model, "
        "which predicts 0.32 mm; without it, 0.54 mm, of which the fit predicts 0.52 mm"
    )
    sigma = 1e-5
    ur10 = pincal.load_robot("ur10", markers=[(0.03, -0.02, 0.1)])
    params = ur10.parameters("full,offsets").identifiable().identifiable
    field = SmoothField.random(ur10, field_mm * 1e-3, seed=7)
    data = pincal.simulate_measurements(
        pincal.random_errors(params, seed=6),
        ur10.random_configurations(200, 8),
        sigma,
        seed=9,
        unmodelled=field,
    )
    _, gp = holdout(params, data, 0.3, seed=1, sigma=sigma, residual_model="gp")
    _, plain = holdout(params, data, 0.3, seed=1, sigma=sigma)
    for stated, value in (
        (measured, gp.stats_after["rms"]),
        (with_gp, gp.expected_rms),
        (measured_plain, plain.stats_after["rms"]),
        (without, plain.expected_rms),
    ):
        assert abs(value * 1e3 - stated) <= 0.015, (stated, value * 1e3)
