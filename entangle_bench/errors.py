"""Typed exceptions: the library raises these, only the CLI prints and exits."""


class EntangleBenchError(Exception):
    """Base class of every error the harness raises on purpose."""


class ParameterError(EntangleBenchError, ValueError):
    """A parameter is outside its allowed range; the message names both."""


class UnknownNameError(EntangleBenchError, KeyError):
    """An unknown registry name; the message lists the known ones."""

    def __init__(self, kind: str, name: str, known: list[str]):
        self.kind, self.name, self.known = kind, name, sorted(known)
        super().__init__(f"unknown {kind} {name!r}; known: {', '.join(self.known)}")

    def __str__(self) -> str:
        return self.args[0]


class MeshError(EntangleBenchError, ValueError):
    """A mesh file is missing, empty, broken or absurdly scaled."""


class FileFormatError(EntangleBenchError, ValueError):
    """A suite, rod-case or curve file is malformed; the message names file, key and problem."""


class DuplicateNameError(EntangleBenchError, ValueError):
    """A name is registered twice in one registry."""

    def __init__(self, kind: str, name: str):
        self.kind, self.name = kind, name
        super().__init__(f"{kind} {name!r} is already registered")


class OutcomeError(EntangleBenchError, RuntimeError):
    """A task decided its outcome twice, or a stable trial ended without one."""
