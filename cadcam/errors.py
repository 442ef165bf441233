"""The error of a spec that cannot be used, here below every layer that may find one (the
spec reader, a mechanism's start, the transcription); :mod:`cadcam.spec` re-exports it."""


class SpecError(ValueError):
    """A spec that cannot be used; the message is one line naming file, key and expected form."""
