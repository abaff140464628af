"""Rover and spawn parameters: the report's appendix C.2 tables, with its initial values as defaults.

This is the one place these defaults live. Where the report's unit is garbled we say what we use.
"""

from __future__ import annotations

import math
from typing import Annotated

from msgspec import Meta, Struct

from schemas.scenario_limits import MAX_RATE_HZ, MAX_ROVERS
from schemas.wire_limits import Coordinate, Finite, Rate, finite


class Params(Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Every float is bounded on both sides (``schemas.wire_limits.finite``): a nan compares false with every bound,
    so it would pass them all.

    Structs check their bounds when converted, not when built: parameters from a file go through the scenario
    loader (``schemas.scenario``, ``schemas.scenario_types``), from anywhere else through
    ``schemas.codec.checked``. Cross-field rules live in ``__post_init__``, which runs on both."""


class SpawnParams(Params, kw_only=True):
    """Table 3: where ``--rovers N`` places a formation of rovers."""

    rover_count: Annotated[int, Meta(ge=1, le=MAX_ROVERS)] = 10
    start_spawn_x: Coordinate = -510.0
    start_spawn_z: Coordinate = 100.0
    spawn_spacing_x: Annotated[float, Meta(gt=0, le=10_000)] = 10.0
    spawn_spacing_z: Annotated[float, Meta(gt=0, le=10_000)] = 10.0
    spawn_group_orientation: Annotated[Finite, Meta(
        description="direction in which a row of the formation runs")] = 90.0
    spawn_individual_orientation: Annotated[Finite, Meta(description="heading of each rover; 0 = +z, 90 = +x")] = 180.0

    def formation(self, count: int) -> list[tuple[float, float, float]]:
        """(x, z, heading) of ``count`` rovers: rows of ceil(sqrt(count)), rows stepping to the group's right.

        With the defaults this reproduces the report's scenarios: rows along +x, the second row 10 m behind.
        """
        per_row = max(1, math.ceil(math.sqrt(count)))
        g = math.radians(self.spawn_group_orientation)
        row_dx, row_dz = math.sin(g), math.cos(g)
        back_dx, back_dz = math.sin(g + math.pi / 2), math.cos(g + math.pi / 2)
        spots = []
        for i in range(count):
            col, row = i % per_row, i // per_row
            x = self.start_spawn_x + col * self.spawn_spacing_x * row_dx + row * self.spawn_spacing_z * back_dx
            z = self.start_spawn_z + col * self.spawn_spacing_x * row_dz + row * self.spawn_spacing_z * back_dz
            spots.append((round(x, 6), round(z, 6), self.spawn_individual_orientation))
        return spots


class NavigationParams(Params, kw_only=True):
    """Table 4."""

    in_place_rotation_speed: Annotated[float, finite(
        gt=0, description="rad/s (the report prints m/s; 2 rad/s ~ 115 deg/s matches its angular_speed)")] = 2.0
    move_action_tolerance_factor: Annotated[float, finite(
        ge=0, description="slack on the perception-range check")] = 0.1
    strict_line_of_sight: Annotated[bool, Meta(
        description="true: the rover's whole body must pass (swept check); false: the centre line only")] = False
    speed_mode_one: Annotated[float, finite(gt=0, description="m/s")] = 1.5
    speed_mode_two: Annotated[float, finite(gt=0, description="m/s")] = 2.5
    speed_mode_three: Annotated[float, finite(gt=0, description="m/s")] = 3.5
    angular_speed: Annotated[float, finite(gt=0, description="deg/s while turning towards a move goal")] = 120.0
    acceleration: Annotated[float, finite(gt=0, description="m/s^2, linear")] = 20.0
    publish_frequency: Annotated[Rate, Meta(description="navigation_status rate, Hz")] = 5.0
    max_slope_deg: Annotated[float, Meta(
        gt=0, le=90, description="steepest traversable slope; steeper is 'terrain'")] = 25.0
    slope_slowdown: Annotated[float, Meta(
        ge=0, lt=1, description="fraction of speed lost climbing at max_slope_deg")] = 0.6
    slip_std: Annotated[float, Meta(ge=0, le=0.5, description="1-sigma slip as a fraction of each move's length")] = 0.0
    heading_noise_std_deg: Annotated[float, Meta(
        ge=0, le=45, description="1-sigma heading error per move or rotate")] = 0.0

    def speed(self, level: int) -> float:
        return (self.speed_mode_one, self.speed_mode_two, self.speed_mode_three)[level - 1]


class PerceptionParams(Params, kw_only=True):
    """Table 5, perception part."""

    field_of_view_degrees: Annotated[float, Meta(gt=0, le=360)] = 210.0
    perception_radius: Annotated[float, finite(gt=0)] = 10.0
    perception_granularity: Annotated[int, Meta(ge=2, le=4096)] = 50
    publish_frequency: Annotated[Rate, Meta(description="perception rate, Hz")] = 5.0
    gyroscope_frequency: Annotated[Rate, Meta(description="gyroscope rate, Hz")] = 20.0
    gyroscope_noise_std_deg: Annotated[float, Meta(ge=0, le=10, description="1-sigma pitch noise")] = 0.0
    sun_sensor: Annotated[bool, Meta(
        description="an absolute heading sensor (a sun sensor, as small planetary rovers carry: the sun's bearing in "
        "the rover's frame against its known azimuth gives the heading in the lander frame), read with the "
        "gyroscope; false: the rover has none and only dead-reckons its heading (the report's Lunar Zebro)")] = False
    sun_sensor_noise_std_deg: Annotated[float, Meta(
        ge=0, le=45, description="1-sigma error of each sun sensor heading reading, independent reading to "
        "reading")] = 2.0

    @property
    def ray_step_deg(self) -> float:
        """Degrees between neighbouring rays: the rays span the field of view, ends included."""
        return self.field_of_view_degrees / (self.perception_granularity - 1)


class CommunicationParams(Params, kw_only=True):
    """Table 5, communication part, plus the lander's radio (the report's environment reached every rover)."""

    comm_range: Annotated[float, finite(gt=0, description="rover radio range, m")] = 10.0
    lander_comm_range: Annotated[float, finite(
        gt=0, description="lander radio range, m; set it to comm_range to make the daisy chain matter")] = 1000.0
    partners_frequency: Annotated[Rate, Meta(description="comm_partners rate, Hz")] = 1.0
    line_of_sight: Annotated[bool, Meta(description="links need line of sight over terrain and walls")] = True
    antenna_height_m: Annotated[float, finite(
        ge=0, description="rover antenna height above ground, for line of sight")] = 0.3
    lander_antenna_height_m: Annotated[float, finite(ge=0, description="the lander's mast, for line of sight")] = 3.0
    latency_s: Annotated[float, Meta(ge=0, le=60, description="per-link delivery delay")] = 0.0
    loss_probability: Annotated[float, Meta(ge=0, le=1, description="chance a transmission is lost on the way")] = 0.0
    release_relays: Annotated[bool, Meta(
        description="at the last goal, once every other rover is done there and its photos are in, the daisy "
                    "chain's relays walk on to the goal too, out of the lander's reach; false keeps them on "
                    "their spots (N3)")] = True
    relay_cut_off_s: Annotated[float, Meta(
        gt=0, le=3600, description="with release_relays, a relay at the last goal that hears no word from the "
                                   "lander for this long (a wall between two spots cuts the chain) walks on "
                                   "to the goal by itself")] = 60.0


class BehaviourParams(Params, kw_only=True):
    """Tables 7 and 8: the rover behaviour's tunables (state flags of those tables are not parameters)."""

    rover_radius: Annotated[float, finite(
        gt=0, description="physical radius, m; also used by the world for collisions")] = 0.5
    max_wait_time: Annotated[float, finite(ge=0, description="s to wait for another rover after a cancel")] = 0.5
    collision_danger_dist: Annotated[float, finite(
        ge=0, description="m ahead at which a rover in the way cancels a move")] = 4.0
    rotate_action: Annotated[Finite, Meta(description="deg to rotate when the view is blocked everywhere")] = 60.0
    turn_step: Annotated[float, finite(gt=0)] = 4.0
    path_area: Annotated[float, finite(ge=0, description="m either side of the path counted as on it")] = 2.0
    scan_angle: Annotated[float, finite(gt=0, description="deg between scanned directions")] = 10.0
    scanner_field_of_view: Annotated[float, Meta(gt=0, le=360)] = 160.0
    extra_distance_between_rovers: Annotated[float, finite(ge=0)] = 2.0
    min_move_size: Annotated[float, finite(gt=0)] = 2.0
    photo_step_deg: Annotated[float, finite(
        gt=0, description="report 10.5.3: a photo every 30 degrees on the rim")] = 30.0


class CameraParams(Params, kw_only=True):
    """The forward camera of report 10.5 (its resolution was configurable there too)."""

    width: Annotated[int, Meta(ge=8, le=4096)] = 160
    height: Annotated[int, Meta(ge=8, le=4096)] = 120
    horizontal_fov_deg: Annotated[float, Meta(gt=0, lt=180)] = 60.0
    mount_height_m: Annotated[float, finite(gt=0, description="camera height above the ground")] = 0.3
    max_range_m: Annotated[float, finite(gt=0, description="farthest rendered distance")] = 300.0
    capture_time_s: Annotated[float, finite(
        ge=0, description="simulated time from a PhotoAction to its Photo (exposure, read-out and encoding; "
                          "the world renders meanwhile)")] = 0.5


class MappingParams(Params, kw_only=True):
    """What a rover tells the lander for its map (``rover_agent.mission.traverse_map``, ``lander_agent.mapping``)."""

    cell_m: Annotated[float, Meta(
        gt=0, le=100, description="side of a map cell, m: the rover keeps one point per cell and kind, the "
                                  "lander's grid uses the same size")] = 1.0
    report_period_s: Annotated[float, Meta(
        ge=1 / MAX_RATE_HZ, le=3600, description="s between two map reports (and resends) to the lander")] = 3.0
    max_cells_per_report: Annotated[int, Meta(
        ge=1, le=20_000, description="bounds one MapReport (5 bytes a cell)")] = 1500
    max_reports_per_send: Annotated[int, Meta(
        ge=1, description="unacknowledged reports sent at once, oldest first")] = 4


class PowerParams(Params, kw_only=True):
    """Battery and solar panel (the report's need N10). Used only when the scenario has a ``sun`` block.

    The report gives no electrical figures for the Lunar Zebro; it gives its size (about 30 cm long, 10.7.1) and
    a top speed of about 1 cm/s. Every default below is therefore a documented assumption for a rover of that
    size, stated with its reasoning; scenarios scale them (a short test mission needs a small battery).
    """

    capacity_wh: Annotated[float, finite(
        gt=0, description="Wh; assumption: two 18650 Li-ion cells (~25 Wh), derated")] = 20.0
    initial_charge_fraction: Annotated[float, Meta(
        ge=0, le=1, description="charge at the start, share of capacity")] = 1.0
    idle_w: Annotated[float, finite(ge=0, description="W while on: avionics and radio receiver (assumption)")] = 1.0
    perception_w: Annotated[float, finite(ge=0, description="W while on: camera and its processing (assumption)")] = 1.5
    move_w: Annotated[tuple[Finite, Finite, Finite], Meta(
        description="W while walking at speed level 1, 2, 3 (assumption: faster legs draw more)")] = (3.0, 4.5, 6.0)
    rotate_w: Annotated[float, finite(ge=0, description="W while turning (assumption: as walking slowly)")] = 3.0
    radio_transmit_j: Annotated[float, finite(ge=0, description="J per radio transmission (assumption)")] = 0.5
    photo_j: Annotated[float, finite(ge=0, description="J per photo taken (assumption)")] = 2.0
    panel_area_m2: Annotated[float, finite(
        ge=0, description="m^2; the deck of a 30 cm x 20 cm rover (report 10.7.1: about 30 cm long)")] = 0.06
    panel_efficiency: Annotated[float, Meta(ge=0, le=1, description="triple-junction space cells (assumption)")] = 0.28
    panel_tilt_deg: Annotated[float, Meta(
        ge=0, le=90, description="tilt from the deck towards the sun's azimuth: 0 = flat; polar rovers tilt "
                                 "their panel up to the low sun")] = 0.0
    panel_height_m: Annotated[float, finite(ge=0, description="height of the panel above ground, for shadows")] = 0.2
    solar_flux_w_m2: Annotated[float, finite(gt=0, description="the solar constant at 1 AU")] = 1361.0
    resume_fraction: Annotated[float, Meta(ge=0, le=1, description="an empty rover restarts above this charge")] = 0.1
    low_charge_fraction: Annotated[float, Meta(
        ge=0, le=1, description="behaviour: below this it does not go into shadow and stops in sun to charge")] = 0.5
    recharge_to_fraction: Annotated[float, Meta(ge=0, le=1, description="behaviour: charges in sun up to this")] = 0.95
    publish_frequency: Annotated[Rate, Meta(description="battery, temperature and sun sensor rate, Hz")] = 1.0

    def __post_init__(self) -> None:
        if self.recharge_to_fraction < self.low_charge_fraction:
            raise ValueError("recharge_to_fraction must be at least low_charge_fraction")
        if min(self.move_w) < 0:
            raise ValueError("move_w must not be negative")

    def move_power(self, level: int) -> float:
        return self.move_w[level - 1]


class ThermalParams(Params, kw_only=True):
    """Rover temperature (the report's need N9): it tends towards the sunlit or the shadowed surface temperature.

    The report gives the surface extremes, 127 C in full sun and -173 C in darkness (4.1.2); those are the
    defaults the rover tends to. How fast it does, and its operating limit, are assumptions.
    """

    initial_c: Annotated[Finite, Meta(description="temperature at the start, C")] = 20.0
    sun_c: Annotated[Finite, Meta(description="temperature a rover in sun tends to, C (report 4.1.2)")] = 127.0
    shadow_c: Annotated[Finite, Meta(description="temperature a rover in shadow tends to, C (report 4.1.2)")] = -173.0
    heat_time_constant_s: Annotated[float, finite(gt=0, description="e-folding time in sun, s (assumption)")] = 7200.0
    cool_time_constant_s: Annotated[float, finite(
        gt=0, description="e-folding time in shadow, s (assumption: insulated, slower than heating)")] = 10800.0
    min_operating_c: Annotated[Finite, Meta(
        description="below this the rover shuts down (N9); assumption: industrial-grade electronics")] = -30.0
    resume_c: Annotated[Finite, Meta(description="a rover shut down by cold restarts above this")] = -20.0

    def __post_init__(self) -> None:
        if self.resume_c < self.min_operating_c:
            raise ValueError("resume_c must be at least min_operating_c")


class WatchdogParams(Params, kw_only=True):
    """LunarSim's: when the world stops waiting for a rover that has stopped making progress."""

    stall_after_s: Annotated[float, Meta(
        gt=0, le=1e6, description="simulated seconds a rover may come no closer to its goal before the world "
                                  "counts it stuck (world_service.outcome.progress); a rover off for want of "
                                  "power or finished is not counted")] = 300.0


class RoverParams(Params, kw_only=True):
    camera: CameraParams = CameraParams()
    navigation: NavigationParams = NavigationParams()
    perception: PerceptionParams = PerceptionParams()
    communication: CommunicationParams = CommunicationParams()
    behaviour: BehaviourParams = BehaviourParams()
    mapping: MappingParams = MappingParams()
    power: PowerParams = PowerParams()
    thermal: ThermalParams = ThermalParams()
    watchdog: WatchdogParams = WatchdogParams()
