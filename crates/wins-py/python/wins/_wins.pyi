"""Type stubs of the native module ``wins._wins`` (the public API is ``wins``)."""

from typing import Any, Dict, Iterator, List, Optional, Tuple

__version__: str

class WinsError(Exception):
    """An error of wins, with its message and causes."""

def read_csi(path: str, nrx: int = 3, ntx: Optional[int] = None) -> Dict[str, Any]: ...

class CsiChunks(Iterator[Dict[str, Any]]):
    def __init__(self, path: str, chunk: int = 10_000, nrx: int = 3, ntx: int = 3) -> None: ...
    def __iter__(self) -> "CsiChunks": ...
    def __next__(self) -> Dict[str, Any]: ...

def read_nexmon(path: str, exact: bool = False) -> Dict[str, Any]: ...
def read_feitcsi(path: str) -> Dict[str, Any]: ...
def read_packets(path: str, format: Optional[str] = None) -> Dict[str, Any]: ...
def read_atheros(path: str) -> Dict[str, Any]: ...
def read_picoscenes(path: str) -> Dict[str, Any]: ...
def check(
    path: str,
    channel: Optional[int] = None,
    calibration: Optional[str] = None,
    format: Optional[str] = None,
) -> str: ...
def aoa(
    path: str,
    ap: Optional[str] = None,
    channel: Optional[int] = None,
    center_freq_hz: Optional[float] = None,
    spacing_m: Optional[float] = None,
    config: Optional[str] = None,
    calibration: Optional[str] = None,
    mode: str = "music",
    group_size: int = 10,
    csi_format: Optional[str] = None,
) -> Tuple[str, str, List[str]]: ...
def run(
    dataset: str,
    out: str,
    config: Optional[str] = None,
    calibration: Optional[str] = None,
    no_calibration: bool = False,
) -> Dict[str, Any]: ...
def simulate(
    out: str,
    scenario: Optional[str] = None,
    family: Optional[str] = None,
    seed: Optional[int] = None,
    duration_s: Optional[float] = None,
    airborne: bool = False,
    card: Optional[str] = None,
) -> str: ...
def default_config() -> str: ...
def scenarios() -> List[Tuple[str, str]]: ...
