"""Control with a fitted model: the inverse (which command gives a desired force) and the on/off baseline.

:func:`invert` solves for the command history on the model's own equations (CasADi collocation +
IPOPT) and reports where the desired force is unreachable; :func:`clipped_on_off` is the classic
closed-loop clipped-optimal law (Dyke et al. 1996) it is compared with.
"""

from duffsym.control.baseline import clipped_on_off
from duffsym.control.inverse import InverseOptions, InverseResult, command_index, invert

__all__ = ["InverseOptions", "InverseResult", "clipped_on_off", "command_index", "invert"]
