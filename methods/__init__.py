"""Registration methods. Each is one module with one class whose constructor takes plain typed
arguments (built by Hydra from ``configs/method/<name>.yaml``) and whose ``register(problem)``
returns a :class:`~catpose.types.RegistrationResult`."""
