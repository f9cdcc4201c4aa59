"""Runtime visibility culling (SPEC 2): the Culler and its stages, one module per stage."""
from .culler import BACKFACE_STAGES, CONSERVATIVE, STAGES, Culler, device_options, parse_stages
from .state import CullResult

__all__ = ["Culler", "CullResult", "STAGES", "CONSERVATIVE", "BACKFACE_STAGES", "device_options",
           "parse_stages"]
