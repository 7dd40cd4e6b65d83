"""Verification: problems whose answer is known independently of geocel (closed forms, conservation laws,
invariances), as functions that ``geocel verify``, the tests and the benchmark scripts share.

* :mod:`.closed_form`: the closed-form solutions (Shield, Lamé, Hill, hypoplastic critical state);
* :mod:`.pile`: Shield's punch (Cartesian grid; and as a scenario in the default set-up of each geometry), the
  wished-in-place pile on the Cartesian grid;
* :mod:`.axisym`: the r–z step's checks (punch on the nodes, thick cylinders, geostatic column, collapse, the
  wished-in-place pile at rest and at slip);
* :mod:`.checks`: the checks of ``geocel verify``.
"""

from .closed_form import SHIELD_SMOOTH
from .pile import limit_over, punch_curve, punch_in_scenario, wished_in_place

__all__ = ["SHIELD_SMOOTH", "limit_over", "punch_curve", "punch_in_scenario", "wished_in_place"]
