"""Registration methods. Each is one module with one class whose constructor takes plain typed
arguments (built by Hydra from ``configs/method/<name>.yaml``) and whose ``register(problem)``
returns a :class:`~catpose.types.RegistrationResult`.

Also here, the choice among K templates (``configs/choice/<rule>.yaml``): which of a view's K
template registrations to keep, without ground truth (:mod:`.template_choice`, its rules
:mod:`.choice_rules` and the cross check's facts :mod:`.cross_check`)."""
