"""The twin's scenarios: where the vehicle dives and what the operator does.

Every scenario starts the same way: the board boots at time 0 with the
vehicle held still just under the surface, the estimator aligns (about 8 s
of fast gains, ``shared/estimator``), the operator arms at ``ARM_S`` in
PASSIVE, the mode the board boots in (later by as much as the board came
up late: the emulated Pico 2's 0.8 s boot; repeating while the vehicle
refuses), sets up the dive (target, velocity, then the
dive's mode: the mode checks of an armed vehicle see the target), and the
vehicle is released half a second after the last set-up command is
accepted. Then:

==================  ==========================================================
name                what it shows
==================  ==========================================================
``passive-drop``    PASSIVE (``PASSIVE_WING_DEG`` on all wings) from 10 m to
                    the bottom; ends 2 s after landing
``target-landing``  TARGET: land on a target 2 m north of the release point
                    from 10 m (``--target``, ``--depth``); needs the controller
``velocity``        VELOCITY: 0.10 m/s north (no descent-speed command);
                    needs the controller; ends 2 s after landing
``bottom-rest``     a PASSIVE drop in 1 m of water, then resting on the bottom
                    until ``--duration`` (default 610 s: ten minutes resting)
==================  ==========================================================
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

from roboray.sim.twin.ground import Action

ARM_S = 9.0
RELEASE_DELAY_S = 0.5


@dataclass(frozen=True)
class Scenario:
    name: str
    bottom_depth: float          #: m
    duration_s: float            #: the longest the run lasts, s
    settle_s: Optional[float]    #: end this long after landing (None: run the whole duration)
    mode: str                    #: the flight mode of the dive
    needs_controller: bool
    target: Optional[tuple] = None
    velocity: Optional[tuple] = None

    def script(self) -> list[Action]:
        """The operator's actions; the vehicle is released after the last one."""
        # arming is refused until the estimator has aligned, 8 s from its
        # first IMU sample: a board that boots slower (the emulated Pico 2
        # runs its start-up at the chip's speed, its first HEARTBEAT at
        # 0.86 s) aligns that much later, and is armed that much later
        # (ground.BOOT_S); keep asking, for a vehicle that refuses for
        # another reason
        acts = [Action(ARM_S, "arm", label="armed", max_tries=15, from_boot=True)]
        after = "armed"
        if self.target is not None:
            north, east = self.target
            acts.append(Action(ARM_S, "target", (north, east, self.bottom_depth), after=after, label="target"))
            after = "target"
        if self.velocity is not None:
            acts.append(Action(ARM_S, "velocity", tuple(self.velocity), after=after, label="velocity"))
            after = "velocity"
        if self.mode != "PASSIVE":
            acts.append(Action(ARM_S, "mode", (self.mode,), after=after, label="mode"))
            after = "mode"
        return acts


NAMES = ("passive-drop", "target-landing", "velocity", "bottom-rest")


def make(name: str, depth: Optional[float] = None, target: Optional[tuple] = None,
         duration: Optional[float] = None) -> Scenario:
    """The scenario ``name`` with the command line's overrides."""
    if name == "passive-drop":
        s = Scenario(name, 10.0, 120.0, 2.0, "PASSIVE", False)
    elif name == "target-landing":
        s = Scenario(name, 10.0, 150.0, 2.0, "TARGET", True, target=(2.0, 0.0))
    elif name == "velocity":
        s = Scenario(name, 10.0, 120.0, 2.0, "VELOCITY", True, velocity=(0.10, 0.0, 0.0))
    elif name == "bottom-rest":
        s = Scenario(name, 1.0, 610.0, None, "PASSIVE", False)
    else:
        raise ValueError("unknown scenario %r; known: %s" % (name, ", ".join(NAMES)))
    if depth is not None:
        if not depth > 0.3:
            raise ValueError("--depth %r: the bottom must be deeper than 0.3 m" % depth)
        s = Scenario(s.name, float(depth), s.duration_s, s.settle_s, s.mode, s.needs_controller, s.target, s.velocity)
    if target is not None:
        if s.mode != "TARGET":
            raise ValueError("--target applies to target-landing, not %s" % name)
        s = Scenario(s.name, s.bottom_depth, s.duration_s, s.settle_s, s.mode, s.needs_controller,
                     (float(target[0]), float(target[1])), s.velocity)
    if duration is not None:
        if not duration > 0:
            raise ValueError("--duration %r must be > 0 s" % duration)
        s = Scenario(s.name, s.bottom_depth, float(duration), s.settle_s, s.mode, s.needs_controller,
                     s.target, s.velocity)
    return s
