"""Finding and loading libvdbscatter.so, and its C declarations (vdbscatter/vdbscatter.h,
status.h, cancel.h) as ctypes types. Every struct here must match the header field for
field."""
import ctypes
import ctypes.util
import os
import sysconfig

SONAME = "libvdbscatter.so.0"
ERROR_MAX = 1024  # VDBS_ERROR_MAX

# vdbs_status
OK = 0
ERR_INPUT = 2
ERR_CANCELLED = 7

# vdbs_message_kind
MESSAGE_OUTPUT = 0
MESSAGE_ERROR = 1
MESSAGE_WARNING = 2
MESSAGE_NOTE = 3
MESSAGE_PROGRESS = 4

# vdbs_arg_kind
ARG_FLAG = 0
ARG_VALUE = 1
ARG_LIST = 2

# vdbs_cancel is volatile sig_atomic_t, an int on every platform glibc supports.
Cancel = ctypes.c_int

# void (*)(void *user, vdbs_message_kind kind, const char *text). A CFUNCTYPE callback (not
# PYFUNCTYPE) takes the GIL when the library calls it, from whatever thread the command runs
# on, and gives it back when it returns.
MessageFn = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_int, ctypes.c_char_p)


class CommandDesc(ctypes.Structure):
    _fields_ = [
        ("argc", ctypes.c_int),
        ("argv", ctypes.POINTER(ctypes.c_char_p)),
        ("message", MessageFn),
        ("message_user", ctypes.c_void_p),
        ("cancel", ctypes.POINTER(Cancel)),
        ("progress", ctypes.c_int),
        ("keep_image", ctypes.c_int),
    ]


class CommandResult(ctypes.Structure):
    _fields_ = [
        ("exit_status", ctypes.c_int),
        ("status", ctypes.c_int),
        ("error", ctypes.c_char * ERROR_MAX),
        ("output", ctypes.POINTER(ctypes.c_char)),
        ("output_size", ctypes.c_size_t),
        ("width", ctypes.c_int),
        ("height", ctypes.c_int),
        ("rgb", ctypes.POINTER(ctypes.c_float)),
        ("se", ctypes.POINTER(ctypes.c_float)),
    ]


class ArgOption(ctypes.Structure):
    _fields_ = [("name", ctypes.c_char_p), ("kind", ctypes.c_int)]


class DenseGrid(ctypes.Structure):
    _fields_ = [
        ("name", ctypes.c_char * 256),
        ("channels", ctypes.c_int),
        ("origin", ctypes.c_int * 3),
        ("size", ctypes.c_int * 3),
        ("index_to_world", (ctypes.c_double * 4) * 3),
        ("values", ctypes.POINTER(ctypes.c_float)),
    ]


class Error(ctypes.Structure):
    _fields_ = [("message", ctypes.c_char * ERROR_MAX)]


def _candidates(package_dir):
    """The installed layout: the package in PREFIX/lib/python3/dist-packages/vdbscatter (or
    site-packages), the library in PREFIX/lib or PREFIX/lib/MULTIARCH. Walking up from the
    package finds the nearest one."""
    multiarch = sysconfig.get_config_var("MULTIARCH")
    folder = os.path.abspath(package_dir)
    while True:
        yield os.path.join(folder, SONAME)
        yield os.path.join(folder, "lib", SONAME)
        if multiarch:
            yield os.path.join(folder, "lib", multiarch, SONAME)
        parent = os.path.dirname(folder)
        if parent == folder:
            return
        folder = parent


def find_library():
    """The path (or name, for the loader's own search) of the library to load: the
    VDBSCATTER_LIBRARY environment variable, else the installed layout around this package,
    else the system's search (ctypes.util.find_library)."""
    explicit = os.environ.get("VDBSCATTER_LIBRARY")
    if explicit:
        if not os.path.isfile(explicit):
            raise ImportError(f"vdbscatter: VDBSCATTER_LIBRARY names {explicit!r}, which is "
                              "not a file")
        return explicit
    for path in _candidates(os.path.dirname(__file__)):
        if os.path.isfile(path):
            return path
    found = ctypes.util.find_library("vdbscatter")
    if found:
        return found
    raise ImportError(
        f"vdbscatter: cannot find {SONAME}: set VDBSCATTER_LIBRARY to its path, or install "
        "the package beside the library (PREFIX/lib/python3/dist-packages/vdbscatter with "
        f"PREFIX/lib/{SONAME})")


def load():
    """The loaded library with its functions' prototypes."""
    path = find_library()
    try:
        # CDLL (not PyDLL): ctypes releases the GIL for the whole of every foreign call, so
        # the main thread keeps running Python (and receiving Ctrl-C) while a command works.
        lib = ctypes.CDLL(path)
    except OSError as e:
        raise ImportError(f"vdbscatter: cannot load {path}: {e}") from e
    lib.vdbs_version.argtypes = []
    lib.vdbs_version.restype = ctypes.c_char_p
    lib.vdbs_command_run.argtypes = [ctypes.POINTER(CommandDesc), ctypes.POINTER(CommandResult)]
    lib.vdbs_command_run.restype = ctypes.c_int
    lib.vdbs_command_result_free.argtypes = [ctypes.POINTER(CommandResult)]
    lib.vdbs_command_result_free.restype = None
    lib.vdbs_command_names.argtypes = []
    lib.vdbs_command_names.restype = ctypes.POINTER(ctypes.c_char_p)
    lib.vdbs_command_option_count.argtypes = [ctypes.c_char_p]
    lib.vdbs_command_option_count.restype = ctypes.c_int
    lib.vdbs_command_option_get.argtypes = [ctypes.c_char_p, ctypes.c_int,
                                            ctypes.POINTER(ArgOption)]
    lib.vdbs_command_option_get.restype = ctypes.c_int
    lib.vdbs_dense_read_all.argtypes = [ctypes.c_char_p, ctypes.c_int64,
                                        ctypes.POINTER(ctypes.POINTER(DenseGrid)),
                                        ctypes.POINTER(ctypes.c_int), ctypes.POINTER(Error)]
    lib.vdbs_dense_read_all.restype = ctypes.c_int
    lib.vdbs_dense_free_all.argtypes = [ctypes.POINTER(DenseGrid), ctypes.c_int]
    lib.vdbs_dense_free_all.restype = None
    lib.path = path
    return lib
