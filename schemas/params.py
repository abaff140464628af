"""Rover and spawn parameters: the report's appendix C.2 tables, with its initial values as defaults.

This is the one place these defaults live. Where the report's unit is garbled we say what we use.
"""

from __future__ import annotations

import math

from pydantic import BaseModel, ConfigDict, Field, model_validator

from schemas.scenario_limits import MAX_RATE_HZ, MAX_ROVERS, Coordinate, Rate


class Params(BaseModel):
    """Every float must be finite: a nan compares false with every bound, so it would pass them all."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class SpawnParams(Params):
    """Table 3: where ``--rovers N`` places a formation of rovers."""

    rover_count: int = Field(10, ge=1, le=MAX_ROVERS)
    start_spawn_x: Coordinate = -510.0
    start_spawn_z: Coordinate = 100.0
    spawn_spacing_x: float = Field(10.0, gt=0, le=10_000)
    spawn_spacing_z: float = Field(10.0, gt=0, le=10_000)
    spawn_group_orientation: float = Field(90.0, description="direction in which a row of the formation runs")
    spawn_individual_orientation: float = Field(180.0, description="heading of each rover; 0 = +z, 90 = +x")

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


class NavigationParams(Params):
    """Table 4."""

    in_place_rotation_speed: float = Field(
        2.0, gt=0, description="rad/s (the report prints m/s; 2 rad/s ~ 115 deg/s matches its angular_speed)"
    )
    move_action_tolerance_factor: float = Field(0.1, ge=0, description="slack on the perception-range check")
    strict_line_of_sight: bool = Field(
        False, description="true: the rover's whole body must pass (swept check); false: the centre line only"
    )
    speed_mode_one: float = Field(1.5, gt=0, description="m/s")
    speed_mode_two: float = Field(2.5, gt=0, description="m/s")
    speed_mode_three: float = Field(3.5, gt=0, description="m/s")
    angular_speed: float = Field(120.0, gt=0, description="deg/s while turning towards a move goal")
    acceleration: float = Field(20.0, gt=0, description="m/s^2, linear")
    publish_frequency: Rate = Field(5.0, description="navigation_status rate, Hz")
    max_slope_deg: float = Field(25.0, gt=0, le=90, description="steepest traversable slope; steeper is 'terrain'")
    slope_slowdown: float = Field(0.6, ge=0, lt=1, description="fraction of speed lost climbing at max_slope_deg")
    slip_std: float = Field(0.0, ge=0, le=0.5, description="1-sigma slip as a fraction of each move's length")
    heading_noise_std_deg: float = Field(0.0, ge=0, le=45, description="1-sigma heading error per move or rotate")

    def speed(self, level: int) -> float:
        return (self.speed_mode_one, self.speed_mode_two, self.speed_mode_three)[level - 1]


class PerceptionParams(Params):
    """Table 5, perception part."""

    field_of_view_degrees: float = Field(210.0, gt=0, le=360)
    perception_radius: float = Field(10.0, gt=0)
    perception_granularity: int = Field(50, ge=2, le=4096)
    publish_frequency: Rate = Field(5.0, description="perception rate, Hz")
    gyroscope_frequency: Rate = Field(20.0, description="gyroscope rate, Hz")
    gyroscope_noise_std_deg: float = Field(0.0, ge=0, le=10, description="1-sigma pitch noise")
    sun_sensor: bool = Field(
        False, description="an absolute heading sensor (a sun sensor, as small planetary rovers carry: the sun's "
        "bearing in the rover's frame against its known azimuth gives the heading in the lander frame), read with "
        "the gyroscope; false: the rover has none and only dead-reckons its heading (the report's Lunar Zebro)")
    sun_sensor_noise_std_deg: float = Field(2.0, ge=0, le=45, description="1-sigma error of each sun sensor heading "
                                            "reading, independent reading to reading")

    @property
    def ray_step_deg(self) -> float:
        """Degrees between neighbouring rays: the rays span the field of view, ends included."""
        return self.field_of_view_degrees / (self.perception_granularity - 1)


class CommunicationParams(Params):
    """Table 5, communication part, plus the lander's radio (the report's environment reached every rover)."""

    comm_range: float = Field(10.0, gt=0, description="rover radio range, m")
    lander_comm_range: float = Field(
        1000.0, gt=0, description="lander radio range, m; set it to comm_range to make the daisy chain matter"
    )
    partners_frequency: Rate = Field(1.0, description="comm_partners rate, Hz")
    line_of_sight: bool = Field(True, description="links need line of sight over terrain and walls")
    antenna_height_m: float = Field(0.3, ge=0, description="rover antenna height above ground, for line of sight")
    lander_antenna_height_m: float = Field(3.0, ge=0, description="the lander's mast, for line of sight")
    latency_s: float = Field(0.0, ge=0, le=60, description="per-link delivery delay")
    loss_probability: float = Field(0.0, ge=0, le=1, description="chance a transmission is lost on the way")
    release_relays: bool = Field(
        True, description="at the last goal, once every other rover is done there and its photos are in, the daisy "
        "chain's relays walk on to the goal too, out of the lander's reach; false keeps them on their spots (N3)"
    )
    relay_cut_off_s: float = Field(
        60.0, gt=0, le=3600, description="with release_relays, a relay at the last goal that hears no word from the "
        "lander for this long (a wall between two spots cuts the chain) walks on to the goal by itself"
    )


class BehaviourParams(Params):
    """Tables 7 and 8: the rover behaviour's tunables (state flags of those tables are not parameters)."""

    rover_radius: float = Field(0.5, gt=0, description="physical radius, m; also used by the world for collisions")
    max_wait_time: float = Field(0.5, ge=0, description="s to wait for another rover after a cancel")
    collision_danger_dist: float = Field(4.0, ge=0, description="m ahead at which a rover in the way cancels a move")
    rotate_action: float = Field(60.0, description="deg to rotate when the view is blocked everywhere")
    turn_step: float = Field(4.0, gt=0)
    path_area: float = Field(2.0, ge=0, description="m either side of the path counted as on it")
    scan_angle: float = Field(10.0, gt=0, description="deg between scanned directions")
    scanner_field_of_view: float = Field(160.0, gt=0, le=360)
    extra_distance_between_rovers: float = Field(2.0, ge=0)
    min_move_size: float = Field(2.0, gt=0)
    photo_step_deg: float = Field(30.0, gt=0, description="report 10.5.3: a photo every 30 degrees on the rim")


class CameraParams(Params):
    """The forward camera of report 10.5 (its resolution was configurable there too)."""

    width: int = Field(160, ge=8, le=4096)
    height: int = Field(120, ge=8, le=4096)
    horizontal_fov_deg: float = Field(60.0, gt=0, lt=180)
    mount_height_m: float = Field(0.3, gt=0, description="camera height above the ground")
    max_range_m: float = Field(300.0, gt=0, description="farthest rendered distance")
    capture_time_s: float = Field(0.5, ge=0, description="simulated time from a PhotoAction to its Photo "
                                  "(exposure, read-out and encoding; the world renders meanwhile)")


class MappingParams(Params):
    """What a rover tells the lander for its map (``rover_agent.mission.traverse_map``, ``lander_agent.mapping``)."""

    cell_m: float = Field(1.0, gt=0, le=100, description="side of a map cell, m: the rover keeps one point per "
                                                         "cell and kind, the lander's grid uses the same size")
    report_period_s: float = Field(3.0, ge=1 / MAX_RATE_HZ, le=3600,
                                   description="s between two map reports (and resends) to the lander")
    max_cells_per_report: int = Field(1500, ge=1, le=20_000, description="bounds one MapReport (5 bytes a cell)")
    max_reports_per_send: int = Field(4, ge=1, description="unacknowledged reports sent at once, oldest first")


class PowerParams(Params):
    """Battery and solar panel (the report's need N10). Used only when the scenario has a ``sun`` block.

    The report gives no electrical figures for the Lunar Zebro; it gives its size (about 30 cm long, 10.7.1) and
    a top speed of about 1 cm/s. Every default below is therefore a documented assumption for a rover of that
    size, stated with its reasoning; scenarios scale them (a short test mission needs a small battery).
    """

    capacity_wh: float = Field(20.0, gt=0, description="Wh; assumption: two 18650 Li-ion cells (~25 Wh), derated")
    initial_charge_fraction: float = Field(1.0, ge=0, le=1, description="charge at the start, share of capacity")
    idle_w: float = Field(1.0, ge=0, description="W while on: avionics and radio receiver (assumption)")
    perception_w: float = Field(1.5, ge=0, description="W while on: camera and its processing (assumption)")
    move_w: tuple[float, float, float] = Field(
        (3.0, 4.5, 6.0), description="W while walking at speed level 1, 2, 3 (assumption: faster legs draw more)")
    rotate_w: float = Field(3.0, ge=0, description="W while turning (assumption: as walking slowly)")
    radio_transmit_j: float = Field(0.5, ge=0, description="J per radio transmission (assumption)")
    photo_j: float = Field(2.0, ge=0, description="J per photo taken (assumption)")
    panel_area_m2: float = Field(0.06, ge=0, description="m^2; the deck of a 30 cm x 20 cm rover (report 10.7.1: "
                                                         "about 30 cm long)")
    panel_efficiency: float = Field(0.28, ge=0, le=1, description="triple-junction space cells (assumption)")
    panel_tilt_deg: float = Field(0.0, ge=0, le=90, description="tilt from the deck towards the sun's azimuth: "
                                                                "0 = flat; polar rovers tilt their panel up to the "
                                                                "low sun")
    panel_height_m: float = Field(0.2, ge=0, description="height of the panel above ground, for shadows")
    solar_flux_w_m2: float = Field(1361.0, gt=0, description="the solar constant at 1 AU")
    resume_fraction: float = Field(0.1, ge=0, le=1, description="an empty rover restarts above this charge")
    low_charge_fraction: float = Field(
        0.5, ge=0, le=1, description="behaviour: below this it does not go into shadow and stops in sun to charge")
    recharge_to_fraction: float = Field(0.95, ge=0, le=1, description="behaviour: charges in sun up to this")
    publish_frequency: Rate = Field(1.0, description="battery, temperature and sun sensor rate, Hz")

    @model_validator(mode="after")
    def _ordered(self) -> PowerParams:
        if self.recharge_to_fraction < self.low_charge_fraction:
            raise ValueError("recharge_to_fraction must be at least low_charge_fraction")
        if min(self.move_w) < 0:
            raise ValueError("move_w must not be negative")
        return self

    def move_power(self, level: int) -> float:
        return self.move_w[level - 1]


class ThermalParams(Params):
    """Rover temperature (the report's need N9): it tends towards the sunlit or the shadowed surface temperature.

    The report gives the surface extremes, 127 C in full sun and -173 C in darkness (4.1.2); those are the
    defaults the rover tends to. How fast it does, and its operating limit, are assumptions.
    """

    initial_c: float = Field(20.0, description="temperature at the start, C")
    sun_c: float = Field(127.0, description="temperature a rover in sun tends to, C (report 4.1.2)")
    shadow_c: float = Field(-173.0, description="temperature a rover in shadow tends to, C (report 4.1.2)")
    heat_time_constant_s: float = Field(7200.0, gt=0, description="e-folding time in sun, s (assumption)")
    cool_time_constant_s: float = Field(10800.0, gt=0, description="e-folding time in shadow, s (assumption: "
                                                                   "insulated, slower than heating)")
    min_operating_c: float = Field(-30.0, description="below this the rover shuts down (N9); assumption: "
                                                      "industrial-grade electronics")
    resume_c: float = Field(-20.0, description="a rover shut down by cold restarts above this")

    @model_validator(mode="after")
    def _ordered(self) -> ThermalParams:
        if self.resume_c < self.min_operating_c:
            raise ValueError("resume_c must be at least min_operating_c")
        return self


class WatchdogParams(Params):
    """LunarSim's: when the world stops waiting for a rover that has stopped making progress."""

    stall_after_s: float = Field(300.0, gt=0, le=1e6, description="simulated seconds a rover may come no closer to "
                                 "its goal before the world counts it stuck (world_service.outcome.progress); a rover "
                                 "off for want of power or finished is not counted")


class RoverParams(Params):
    camera: CameraParams = CameraParams()
    navigation: NavigationParams = NavigationParams()
    perception: PerceptionParams = PerceptionParams()
    communication: CommunicationParams = CommunicationParams()
    behaviour: BehaviourParams = BehaviourParams()
    mapping: MappingParams = MappingParams()
    power: PowerParams = PowerParams()
    thermal: ThermalParams = ThermalParams()
    watchdog: WatchdogParams = WatchdogParams()
