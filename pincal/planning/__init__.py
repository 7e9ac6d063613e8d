"""Choosing the measurement configurations: the plan (:mod:`.plan`), what the workcell allows
(:mod:`.constraints`, :mod:`.feasibility`), the test poses of a design (:mod:`.objectives`; the
criteria are :mod:`pincal.evaluation`'s), the search methods (:mod:`.exchange`,
:mod:`.continuous`, run by :mod:`.multistart`), the search stage (:mod:`.search`), the driver
:func:`~pincal.planning.driver.design` and its options (:mod:`.options`: Search, Safety, Loads),
the values between its stages (:mod:`.settings`), what it returns (:mod:`.results`), the
random-plan baseline (:mod:`.baselines`), the instrument's position chosen with the plan
(:mod:`.placement`) and the smallest safety margins of a plan (:mod:`.safety`). The constraints'
names are public in :mod:`pincal.planning.constraints`."""

from pincal.planning.baselines import random_plans
from pincal.planning.driver import design
from pincal.planning.options import Loads, Safety, Search
from pincal.planning.placement import Placement, Sight, place_instrument
from pincal.planning.plan import Plan
from pincal.planning.results import DesignResult, RandomPlans, StartRecord
from pincal.planning.safety import SafetyReport, safety_margins

__all__ = [
    "DesignResult",
    "Loads",
    "Placement",
    "Plan",
    "RandomPlans",
    "Safety",
    "SafetyReport",
    "Search",
    "Sight",
    "StartRecord",
    "design",
    "place_instrument",
    "random_plans",
    "safety_margins",
]
