"""Which contact model a pattern's `system(contact=...)` builds."""

from .._limits import CONTACT_SAMPLING
from ._tables import sampling_pair

# The contact models by name: "plate", exact plate geometry with continuous collision detection
# (`PlateContact`); "sampled", points sampled on every panel's rings and rim against the others'
# faces (`PanelContact`, the model before exact plates: kept for comparison and its speed).
CONTACT_MODELS = ("plate", "sampled")
DEFAULT_CONTACT = "plate"


def contact_kind(contact: bool | str) -> str | None:
    """The contact model named by a `contact` argument: `True` the default (`DEFAULT_CONTACT`),
    `False` none (panels pass through each other: the paper's model), or a name in
    `CONTACT_MODELS`; otherwise a one-line `ValueError`."""
    if contact is True:
        return DEFAULT_CONTACT
    if contact is False or contact is None:
        return None
    if isinstance(contact, str) and contact in CONTACT_MODELS:
        return contact
    raise ValueError(
        f"contact must be True, False or one of {', '.join(map(repr, CONTACT_MODELS))}, got "
        f"{contact!r}."
    )


def check_sampling(kind: str | None, sampling) -> None:
    """Refuse, in one line, a `contact_sampling` other than the default for a model that takes
    none (only `"sampled"` has sample points; the plate model is exact)."""
    if kind == "sampled":
        sampling_pair(sampling)
    elif not _is_default(sampling, CONTACT_SAMPLING):
        raise ValueError(
            f"contact_sampling applies to contact='sampled' only (the {kind or 'no'} contact model "
            "takes no sample points); pass contact='sampled' with it, or leave it out."
        )


def _is_default(sampling, default) -> bool:
    try:
        return tuple(sampling) == tuple(default)
    except TypeError:
        return False
