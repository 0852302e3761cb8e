"""Type stubs of the native module fs020n._fs020n (re-exported by fs020n)."""

from __future__ import annotations

from os import PathLike
from types import TracebackType
from typing import Any, Dict, Iterable, List, Literal, Optional, Sequence, Tuple, Type, TypedDict, Union

from typing_extensions import Self

__version__: str
HOME: List[float]

#: Six numbers: a list, a tuple, a numpy array or any iterable of numbers.
Six = Iterable[float]
#: N rows of six numbers (a list of lists, an N x 6 numpy array, ...).
Rows = Iterable[Iterable[float]]
Pose = Tuple[float, float, float, float, float, float]

class RttStats(TypedDict):
    count: int
    min_s: float
    mean_s: float
    p99_s: float
    max_s: float

class RobotStats(TypedDict):
    requests: int
    replies: int
    keepalive_polls: int
    late_replies: int
    reconnects: int
    links_lost: int
    refused_before_sending: int
    stream_samples: int
    stream_underruns: int
    stream_late_replies: int
    record_errors: int
    timer_step_s: Optional[float]
    rtt: RttStats

class ServoStats(TypedDict):
    pushes: int
    refused: int
    sent: int
    coalesced: int
    unsent: int
    push_interval_mean_s: float
    push_interval_max_s: float
    push_to_send_mean_s: float
    push_to_send_max_s: float
    rtt_mean_s: float
    rtt_max_s: float
    tracking_error_max_deg: float
    tracking_error_rms_deg: float
    tracking_samples: int

def fk(joints: Six) -> Pose:
    """Flange pose (X, Y, Z mm; O, A, T deg) at joints (deg)."""

def ik(pose: Six, near: Optional[Six] = None) -> List[List[float]]:
    """Every in-range joint solution (deg) for a pose; nearest to `near` first."""

def joint_limits() -> List[Tuple[float, float]]:
    """(min, max) of each joint, degrees."""

class Status:
    error: int
    error_name: Optional[str]
    error_message: Optional[str]
    run: bool
    repeat: bool
    teach_lock: bool
    power: bool
    program_running: bool
    timer: Optional[float]
    joints: List[float]
    pose: Pose
    blockers: List[Tuple[str, str]]
    age_s: float
    @property
    def ready(self) -> bool: ...

class MoveReport:
    reached: bool
    duration_s: float
    error_deg: float
    final_joints: List[float]
    target: List[float]

class Move:
    def wait(self, timeout: Optional[float] = None) -> MoveReport: ...
    def cancel(self) -> None: ...
    def done(self) -> bool: ...
    @property
    def progress(self) -> Optional[float]: ...
    @property
    def remaining_deg(self) -> Optional[float]: ...
    @property
    def target(self) -> List[float]: ...
    @property
    def planned_duration_s(self) -> float: ...

class StreamReport:
    outcome: Literal["completed", "cancelled"]
    samples_sent: int
    late_replies: int
    underruns: int
    tracking_error_max_deg: float
    tracking_error_rms_deg: float
    tracking_samples: int
    final_error_deg: float
    settled: bool
    duration_s: float
    rtt_mean_s: float
    rtt_max_s: float
    lag_s: Optional[float]
    lead_s: float

class Stream:
    def wait(self) -> StreamReport: ...
    def cancel(self) -> None: ...
    def done(self) -> bool: ...
    @property
    def progress(self) -> float: ...

class ServoReport:
    outcome: Literal["stopped", "cancelled", "watchdog"]
    stats: ServoStats
    final_joints: Optional[List[float]]
    duration_s: float

class Servo:
    def push(self, q: Six, qd: Optional[Six] = None, qdd: Optional[Six] = None) -> None: ...
    def stop(self) -> ServoReport: ...
    def stats(self) -> ServoStats: ...
    def done(self) -> bool: ...
    def __enter__(self) -> Self: ...
    def __exit__(
        self,
        ty: Optional[Type[BaseException]],
        value: Optional[BaseException],
        tb: Optional[TracebackType],
    ) -> bool: ...

class Robot:
    def __init__(
        self,
        address: str,
        *,
        connect_timeout: float = 10.0,
        reply_timeout: float = 1.0,
        keepalive_period: float = 0.1,
        record: Union[str, PathLike[str], None] = None,
        record_format: Optional[Literal["csv", "jsonl"]] = None,
    ) -> None: ...
    @property
    def address(self) -> str: ...
    @property
    def is_connected(self) -> bool: ...
    @property
    def link_error(self) -> Optional[str]: ...
    def status(self, fresh: bool = True) -> Status: ...
    def preflight(self) -> None: ...
    def set_speed(self, percent: float) -> Status: ...
    def start(self) -> None: ...
    def stop(self) -> Status: ...
    def cancel(self) -> Status: ...
    def move_joints(
        self,
        target: Six,
        *,
        wait: bool = True,
        timeout: Optional[float] = None,
        tolerance: float = 0.1,
        settle: float = 0.1,
        hold_timeout: Optional[float] = None,
    ) -> Any:
        """MoveReport with wait=True, Move with wait=False."""
    def move_pose(
        self,
        *pose: Any,
        wait: bool = True,
        timeout: Optional[float] = None,
        tolerance: float = 0.1,
        settle: float = 0.1,
        hold_timeout: Optional[float] = None,
    ) -> Any:
        """MoveReport with wait=True, Move with wait=False."""
    def stream(
        self,
        times: Iterable[float],
        positions: Rows,
        velocities: Optional[Rows] = None,
        accelerations: Optional[Rows] = None,
        *,
        mode: Literal["cmd7", "cmd6"] = "cmd7",
        rate: float = 50.0,
        lookahead: float = 2.0,
        max_step_deg: float = 2.0,
        start_tolerance_deg: float = 1.0,
        end_tolerance_deg: float = 0.5,
        end_timeout: float = 3.0,
        lag_compensation: Union[Literal["online", "off"], float, None] = None,
        pacing: Literal["held", "extrapolated"] = "held",
        wait: bool = True,
    ) -> Any:
        """StreamReport with wait=True, Stream with wait=False."""
    def servo(
        self,
        *,
        lookahead: float = 2.0,
        watchdog: float = 0.2,
        on_watchdog: Literal["stop_program", "brake"] = "stop_program",
        max_step_deg: float = 2.0,
        start_tolerance_deg: float = 1.0,
        estimate_velocity: bool = True,
    ) -> Servo: ...
    def send_raw(self, text: str, *, allow_motion: bool = False) -> str: ...
    def stats(self) -> RobotStats: ...
    def server_time(self) -> Optional[float]: ...
    def reconnect(self) -> None: ...
    def close(self) -> None: ...
    def __enter__(self) -> Self: ...
    def __exit__(
        self,
        ty: Optional[Type[BaseException]],
        value: Optional[BaseException],
        tb: Optional[TracebackType],
    ) -> bool: ...

class Emulator:
    def __init__(
        self,
        *,
        port: int = 0,
        joints: Optional[Six] = None,
        monitor_speed: Optional[float] = None,
        power: bool = True,
        run: bool = True,
        repeat: bool = True,
        teach_lock: bool = False,
        error: Union[str, int, None] = None,
        pendant: bool = False,
        terminal: bool = False,
        bare: bool = False,
        as_program: Union[str, PathLike[str], None] = None,
        stubs: Sequence[str] = (),
        address: Optional[str] = None,
        hosts: Optional[Dict[str, str]] = None,
        port_map: Optional[Dict[int, int]] = None,
        pcexecute: Sequence[str] = (),
        execute: Optional[str] = None,
        signals: Optional[Dict[int, bool]] = None,
    ) -> None: ...
    @property
    def address(self) -> str: ...
    @property
    def port(self) -> int: ...
    @property
    def program_ports(self) -> Dict[int, int]: ...
    def wait_port(self, port: int, timeout: float = 5.0) -> int: ...
    @property
    def network(self) -> Dict[str, Any]: ...
    @property
    def pendant_address(self) -> Optional[str]: ...
    @property
    def terminal_address(self) -> Optional[str]: ...
    def power_cycle(self) -> List[Tuple[int, str]]: ...
    @property
    def programs(self) -> List[str]: ...
    @property
    def joints(self) -> List[float]: ...
    @property
    def panel(self) -> Dict[str, bool]: ...
    def set_panel(
        self,
        *,
        power: Optional[bool] = None,
        run: Optional[bool] = None,
        repeat: Optional[bool] = None,
        teach_lock: Optional[bool] = None,
    ) -> None: ...
    def press_estop(self) -> None: ...
    def release_estop(self) -> None: ...
    def raise_error(self, code: Union[str, int]) -> None: ...
    def reset_error(self) -> None: ...
    @property
    def error(self) -> int: ...
    @property
    def error_name(self) -> Optional[str]: ...
    @property
    def monitor_speed(self) -> float: ...
    def set_monitor_speed(self, percent: float) -> None: ...
    @property
    def program_running(self) -> bool: ...
    @property
    def session_open(self) -> bool: ...
    @property
    def newest_command(self) -> Optional[float]: ...
    @property
    def last_session_end(
        self,
    ) -> Optional[Literal["end_command", "receive_timeout", "send_timeout", "disconnected", "fault"]]: ...
    @property
    def counters(self) -> Dict[str, int]: ...
    def snapshot(self) -> Dict[str, Any]: ...
    def interface_panel(self) -> Optional[Dict[str, Any]]: ...
    def inject(self, kind: str, **params: Union[None, bool, int, float, str]) -> None: ...
    def drop_connection(self) -> None: ...
    def stop(self) -> None: ...
    @property
    def running(self) -> bool: ...
    def __enter__(self) -> Self: ...
    def __exit__(
        self,
        ty: Optional[Type[BaseException]],
        value: Optional[BaseException],
        tb: Optional[TracebackType],
    ) -> bool: ...
