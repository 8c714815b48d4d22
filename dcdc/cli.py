"""The ``dcdc`` command line: a thin layer over the Python API.

Each verb lives next to the code it drives and is imported only when used, so
``dcdc --help`` stays fast and a verb never pays for another's imports (torch, numba).
A :class:`~dcdc.errors.DcdcError`, a usage mistake (click's usage errors) and a refusal of
the system (``OSError``: a full disk, a name too long) become one line ``error: ...`` on
stderr and exit status 2; no traceback.
"""
from __future__ import annotations

import functools
import importlib
import sys

import click

from .errors import DcdcError, Interrupted

NO_ARGS_IS_HELP = getattr(click.exceptions, "NoArgsIsHelpError", ())

# verb -> "module:attribute" of a click command or group
COMMANDS = {
    "demo": "dcdc.demo:demo_command",
    "validate-sph": "dcdc.sph.validate:validate_command",
    "scene": "dcdc.scene.cli:scene_group",
    "generate": "dcdc.data.generate:generate_command",
    "dataset": "dcdc.data.cli:dataset_group",
    "train": "dcdc.train.cli:train_command",
    "render": "dcdc.render.cli:render_command",
    "export": "dcdc.render.cli:export_command",
    "view": "dcdc.render.cli:view_command",
    "simulate": "dcdc.evaluate.cli:simulate_command",
    "evaluate": "dcdc.evaluate.cli:evaluate_command",
    "suite": "dcdc.evaluate.suite:suite_group",
    "model": "dcdc.model.cli:model_group",
}
BENCHMARKS = {
    "sph": "dcdc.sph.benchmark:benchmark_command",
    "cconv": "dcdc.model.benchmark:cconv_command",
    "model": "dcdc.model.benchmark:model_command",
    "train": "dcdc.train.benchmark:train_benchmark_command",
    "render": "dcdc.render.benchmark:benchmark_command",
    "geometry": "dcdc.scene.benchmark:benchmark_command",
    "table1": "dcdc.evaluate.table1:table1_command",
}


class LazyGroup(click.Group):
    """A click group whose sub-commands are imported on first use."""

    def __init__(self, *args, lazy: dict[str, str] | None = None, **kwargs):
        super().__init__(*args, **kwargs)
        self.lazy = lazy or {}

    def list_commands(self, ctx):
        return sorted(set(super().list_commands(ctx)) | set(self.lazy))

    def get_command(self, ctx, name):
        if name in self.lazy:
            module, attr = self.lazy[name].split(":")
            try:
                return _checked_first(getattr(importlib.import_module(module), attr))
            except ModuleNotFoundError as e:
                if e.name and module.startswith(e.name):  # the verb's own module is absent
                    return None
                raise
        return super().get_command(ctx, name)


REPORT_OPTIONS = ("--json",)  # options naming a report file written after the work


def _checked_first(cmd):
    """Make ``cmd`` check, before it runs, its report file (``--json FILE``: a folder that
    cannot be created or written is an error line at once, not after minutes of work; a
    missing one is created) and its ``--device`` (as ``dcdc train`` does: cpu, or cuda
    where torch has it)."""
    if not isinstance(cmd, click.Command) or getattr(cmd, "_checked_first", False):
        return cmd
    options = [p for p in cmd.params if isinstance(p, click.Option) and not p.is_flag]
    reports = [p.name for p in options if any(o in REPORT_OPTIONS for o in p.opts)]
    devices = [p.name for p in options if "--device" in p.opts]
    if (reports or devices) and cmd.callback is not None:
        callback = cmd.callback

        @functools.wraps(callback)
        def checked(*args, **kwargs):
            from pathlib import Path

            from .outputs import check_dir, check_file
            for name in reports:
                if kwargs.get(name):
                    folder = Path(kwargs[name]).parent
                    if not folder.exists():  # created, as the report writers do
                        check_dir(folder).mkdir(parents=True, exist_ok=True)
                    check_file(kwargs[name], overwrite=True)
            for name in devices:
                if kwargs.get(name) not in (None, "cpu"):
                    check_device(str(kwargs[name]))
            return callback(*args, **kwargs)
        cmd.callback = checked
    cmd._checked_first = True
    return cmd


def check_device(device: str) -> None:
    """Refuse a ``--device`` torch does not know or cannot use here (``dcdc train``'s rule:
    :func:`dcdc.train.trainer.resolve_device`; ``cuda:N`` names one GPU)."""
    import torch

    from .train.trainer import Dist, resolve_device
    try:
        dev = torch.device(device)
    except (RuntimeError, ValueError):
        dev = None
    resolve_device(dev.type if dev is not None else device, Dist())
    if dev is not None and dev.type == "cuda" and dev.index is not None \
            and dev.index >= torch.cuda.device_count():
        raise DcdcError(f"--device {device}: torch sees {torch.cuda.device_count()} CUDA "
                        f"device(s)")


@click.group(cls=LazyGroup, lazy=COMMANDS, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="dcdc")
def cli():
    """dcdc: learned (density-conditioned CConv) and classical (SPH) multiphase fluids."""


@cli.group(cls=LazyGroup, lazy=BENCHMARKS)
def benchmark():
    """Measure speed on this machine (tables on stdout, --json for a file)."""


def main(argv=None):
    try:
        cli.main(args=argv, prog_name="dcdc", standalone_mode=False)
    except Interrupted as e:  # Ctrl-C / SIGTERM: "aborted", 128 + signal (dcdc.data.interrupt)
        click.echo(str(e), err=True)
        sys.exit(e.exit_code)
    except DcdcError as e:
        _fail(str(e))
    except click.exceptions.Abort:
        click.echo("aborted", err=True)
        sys.exit(130)
    except NO_ARGS_IS_HELP as e:  # a group without its command: the group's help
        click.echo(e.ctx.get_help())
        sys.exit(e.exit_code)
    except click.UsageError as e:  # a bad option or argument: one line, like every error
        _fail(f"{e.format_message()}{_help_hint(e.ctx)}", e.exit_code)
    except click.ClickException as e:
        _fail(e.format_message(), e.exit_code)
    except click.exceptions.Exit as e:
        sys.exit(e.exit_code)
    except OSError as e:  # the system refused (a full disk, a path too long) outside a writer
        _fail(_os_message(e))
    except RecursionError:
        _fail("input nested too deeply to read (arrays or tables inside each other)")
    except MemoryError:
        _fail("out of memory; try a smaller scene, fewer frames or a smaller image")


def _fail(message: str, code: int = 2):
    text = " ".join(str(message).split())  # one line, whatever the message holds
    click.echo(f"error: {text}", err=True)
    sys.exit(code)


def _help_hint(ctx) -> str:
    return f" (see '{ctx.command_path} --help')" if ctx is not None else ""


def _os_message(e: OSError) -> str:
    import errno
    why = "no space left on the device" if e.errno == errno.ENOSPC else (e.strerror or str(e))
    return f"{e.filename}: {why}" if e.filename is not None else why

if __name__ == "__main__":
    main()
