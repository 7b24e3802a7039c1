"""The coordinated planner: decoupled S-curve schedules, coordinated conflict-free.

- :mod:`.schedule`: each arm's fastest schedule alone (``ArmSchedule``, ``Step``), fast exact
  link clearances of sampled poses
- :mod:`.routing`: elbow branches that keep out of the neighbours' poses; tucked transits
- :mod:`.coordinate`: all arms leg by leg, each leg booked at its earliest clear time
- :mod:`.serial`: the fallback when booking deadlocks: the arms take turns
- :mod:`.alone`: the last resort, :func:`.alone.one_at_a_time`: one arm at a time, the others
  resting (moved out of the way where they must be)
- :mod:`.legs`, :mod:`.trace`, :mod:`.candidate`: an arm's work as legs; a record of a
  coordinator run to resume from; one coordinated candidate
- :mod:`.planner`: :func:`plan_coordinated`: candidates, budget, verification
"""

from .planner import CoordinatedOptions, CoordinatedResult, find_coordinated, plan_coordinated

__all__ = ["CoordinatedOptions", "CoordinatedResult", "find_coordinated", "plan_coordinated"]
