"""Runtime visibility culling (SPEC 2): the Culler and its stages, one module per stage."""
from .culler import CONSERVATIVE, STAGES, Culler, parse_stages
from .state import CullResult

__all__ = ["Culler", "CullResult", "STAGES", "CONSERVATIVE", "parse_stages"]
