"""Shared test helpers: run the ``dcdc`` command line in-process."""
from dcdc.cli import main


def dcdc_exit(*args) -> int:
    """Exit status of ``dcdc ARGS`` (0 when it returns normally)."""
    try:
        main([str(a) for a in args])
    except SystemExit as e:
        return e.code or 0
    return 0


def dcdc_output(args, capsys) -> tuple[int, str, str]:
    """(exit status, stdout, stderr) of ``dcdc ARGS``."""
    code = dcdc_exit(*args)
    out = capsys.readouterr()
    return code, out.out, out.err


def dcdc(capsys, *args) -> tuple[int, str, str]:
    """(exit status, stdout, stderr) of ``dcdc ARGS`` (any argument turned into a string)."""
    return dcdc_output([str(a) for a in args], capsys)
