"""The brick's flash file system, as the firmware's loader (``c_loader``/``d_loader``) keeps it.

What the system commands (OPENWRITE, WRITE, CLOSE, OPENREAD, READ, DELETE,
FINDFIRST, FINDNEXT, ...) and a program's file system calls see:

* file names of at most 19 characters, matched without regard to case
  (the stored name keeps its case); at most 127 files; about 120 KB of user
  flash in 256-byte sectors, each file taking ``ceil((size + 36 + 2 x
  sectors) / 256)`` of them;
* 16 handles, shared by every user of the loader: a running program holds its
  own file open, so deleting it fails with "file is busy";
* a program or other *system* file written with OPENWRITE appears only when it
  is closed complete; closed early it is discarded. A *data* file (OPENWRITEDATA,
  a program's ``CreateFile``) exists from its creation and keeps what was
  written;
* writing past the declared size keeps the declared size and reports
  "end of file expected"; reading past the end returns what there was and
  "end of file";
* patterns: ``*.*`` (everything), ``name.*`` (that name, any extension),
  ``*.ext`` (that extension), or one full name.

Every operation returns the loader's status byte (``SUCCESS`` 0x00 or one of
the 0x81-0x93 codes below) and the handle, as the replies carry them.
"""
from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["Flash", "FlashFile", "SUCCESS", "NOMOREHANDLES", "NOSPACE", "NOMOREFILES",
           "EOFEXSPECTED", "ENDOFFILE", "FILENOTFOUND", "HANDLEALREADYCLOSED", "FILEISBUSY",
           "APPENDNOTPOSSIBLE", "FILEISFULL", "FILEEXISTS", "ILLEGALFILENAME", "ILLEGALHANDLE",
           "STATUS_NAMES", "FILENAME_LENGTH", "MAX_HANDLES"]

SUCCESS = 0x00
NOMOREHANDLES = 0x81
NOSPACE = 0x82
NOMOREFILES = 0x83
EOFEXSPECTED = 0x84
ENDOFFILE = 0x85
NOTLINEARFILE = 0x86
FILENOTFOUND = 0x87
HANDLEALREADYCLOSED = 0x88
NOLINEARSPACE = 0x89
UNDEFINEDERROR = 0x8A
FILEISBUSY = 0x8B
NOWRITEBUFFERS = 0x8C
APPENDNOTPOSSIBLE = 0x8D
FILEISFULL = 0x8E
FILEEXISTS = 0x8F
MODULENOTFOUND = 0x90
OUTOFBOUNDERY = 0x91
ILLEGALFILENAME = 0x92
ILLEGALHANDLE = 0x93

STATUS_NAMES = {
    SUCCESS: "success", NOMOREHANDLES: "no more handles", NOSPACE: "no space",
    NOMOREFILES: "no more files", EOFEXSPECTED: "end of file expected",
    ENDOFFILE: "end of file", NOTLINEARFILE: "not a linear file", FILENOTFOUND: "file not found",
    HANDLEALREADYCLOSED: "handle already closed", NOLINEARSPACE: "no linear space",
    UNDEFINEDERROR: "undefined error", FILEISBUSY: "file is busy",
    NOWRITEBUFFERS: "no write buffers", APPENDNOTPOSSIBLE: "append not possible",
    FILEISFULL: "file is full", FILEEXISTS: "file exists", MODULENOTFOUND: "module not found",
    OUTOFBOUNDERY: "out of boundary", ILLEGALFILENAME: "illegal file name",
    ILLEGALHANDLE: "illegal handle",
}

FILENAME_LENGTH = 19
MAX_HANDLES = 16
MAX_FILES = 127
SECTOR = 256
USER_FLASH_SECTORS = 477  # 0x1DD00 bytes between the firmware and the file table
_HEADER_FIXED = FILENAME_LENGTH + 1 + 4 + 4 + 4 + 2 + 2
_WRITE_BUFFERS = 4


def file_sectors(size: int) -> int:
    """Sectors a file of ``size`` bytes takes (``dLoaderCreateFileHeader``)."""
    total = size + _HEADER_FIXED
    n = (total - 1) >> 8
    total += n << 1
    extra = ((total - 1) >> 8) - n
    if extra:
        total += extra << 1
    return ((total - 1) >> 8) + 1


@dataclass(eq=False)
class FlashFile:
    name: str
    size: int  # declared size (FileSize)
    data: bytearray  # bytes written so far (DataSize = len(data) for data files)
    data_file: bool = False

    @property
    def data_size(self) -> int:
        return len(self.data)


@dataclass(eq=False)
class _Handle:
    mode: str  # "read", "write", "search", "busy" (a program's hold)
    file: FlashFile | None = None
    pos: int = 0
    pattern: tuple[str, str] = ("all", "")
    index: int = -1  # search position in the file table
    overflow: bool = False
    pending: bool = False  # a system file being downloaded, not in the table yet


@dataclass
class Flash:
    """The file table and the loader's handles."""

    files: list[FlashFile] = field(default_factory=list)
    handles: list[_Handle | None] = field(default_factory=lambda: [None] * MAX_HANDLES)

    # -- queries ---------------------------------------------------------------------

    def find(self, name: str) -> FlashFile | None:
        low = name.lower()
        for f in self.files:
            if f.name.lower() == low:
                return f
        return None

    def names(self) -> list[str]:
        return [f.name for f in self.files]

    def read_all(self, name: str) -> bytes | None:
        f = self.find(name)
        return None if f is None else bytes(f.data)

    def free_sectors(self) -> int:
        used = sum(file_sectors(f.size) for f in self.files)
        used += sum(file_sectors(h.file.size) for h in self.handles
                    if h is not None and h.pending and h.file is not None)
        return USER_FLASH_SECTORS - used

    def install(self, name: str, data: bytes) -> None:
        """Put a complete file in flash (what a download leaves behind)."""
        if not _valid_name(name):
            raise ValueError(f"invalid NXT file name {name!r} (1 to {FILENAME_LENGTH} characters)")
        old = self.find(name)
        if old is not None:
            self.files.remove(old)
        if len(self.files) >= MAX_FILES or file_sectors(len(data)) > self.free_sectors():
            raise ValueError(f"no room in flash for {name} ({len(data)} bytes)")
        self.files.append(FlashFile(name, len(data), bytearray(data)))

    # -- handles -----------------------------------------------------------------------

    def _new_handle(self, h: _Handle) -> int | None:
        for i, slot in enumerate(self.handles):
            if slot is None:
                self.handles[i] = h
                return i
        return None

    def _busy(self, f: FlashFile, except_handle: int = -1) -> bool:
        return any(h is not None and h.file is f and h.mode in ("read", "write", "busy")
                   and i != except_handle for i, h in enumerate(self.handles))

    def hold(self, name: str) -> int | None:
        """Open ``name`` for a running program (kept open until :meth:`close`)."""
        f = self.find(name)
        if f is None:
            return None
        return self._new_handle(_Handle("busy", f))

    # -- loader operations ------------------------------------------------------------------

    def open_write(self, name: str, size: int, *, data_file: bool = False) -> tuple[int, int]:
        """OPENWRITE / OPENWRITELINEAR (system file) or OPENWRITEDATA (data file)."""
        h = self._free_index()
        if h is None:
            return NOMOREHANDLES, 0
        if not _valid_name(name):
            return ILLEGALFILENAME, h
        if self.find(name) is not None:
            return FILEEXISTS, h
        if any(x is not None and x.pending and x.file is not None
               and x.file.name.lower() == name.lower() for x in self.handles):
            return FILEISBUSY, h
        if len(self.files) >= MAX_FILES:
            return NOMOREFILES, h
        if sum(1 for x in self.handles if x is not None and x.mode == "write") >= _WRITE_BUFFERS:
            return NOWRITEBUFFERS, h
        if file_sectors(size) > self.free_sectors():
            return NOSPACE, h
        f = FlashFile(name, size, bytearray(), data_file)
        if data_file:
            self.files.append(f)
        self.handles[h] = _Handle("write", f, pending=not data_file)
        return SUCCESS, h

    def open_append(self, name: str) -> tuple[int, int, int]:
        """OPENAPPENDDATA: (status, handle, bytes still free in the file)."""
        h = self._free_index()
        if h is None:
            return NOMOREHANDLES, 0, 0
        f = self.find(name)
        if f is None:
            return FILENOTFOUND, h, 0
        if not f.data_file or f.data_size >= f.size:
            return APPENDNOTPOSSIBLE, h, 0
        if self._busy(f):
            return FILEISBUSY, h, 0
        self.handles[h] = _Handle("write", f)
        return SUCCESS, h, f.size - f.data_size

    def write(self, handle: int, data: bytes) -> tuple[int, int, int]:
        """WRITE: (status, handle, bytes written)."""
        h = self._get(handle, "write")
        if h is None:
            return ILLEGALHANDLE, handle & 0xFF, 0
        assert h.file is not None
        room = h.file.size - h.file.data_size
        chunk = data[:room]
        if len(chunk) < len(data):
            h.overflow = True
        h.file.data += chunk
        return (EOFEXSPECTED if h.overflow else SUCCESS), handle, len(chunk)

    def open_read(self, name: str) -> tuple[int, int, int]:
        """OPENREAD: (status, handle, data size)."""
        h = self._free_index()
        if h is None:
            return NOMOREHANDLES, 0, 0
        if not _valid_name(name):
            return ILLEGALFILENAME, h, 0
        f = self.find(name)
        if f is None or f.size == 0:
            return FILENOTFOUND, h, 0
        self.handles[h] = _Handle("read", f)
        return SUCCESS, h, f.data_size

    def read(self, handle: int, count: int) -> tuple[int, int, bytes]:
        """READ: (status, handle, the bytes read — fewer at the end of the file)."""
        h = self._get(handle, "read")
        if h is None:
            return ILLEGALHANDLE, handle & 0xFF, b""
        assert h.file is not None
        data = bytes(h.file.data[h.pos:h.pos + count])
        h.pos += len(data)
        return (ENDOFFILE if len(data) < count else SUCCESS), handle, data

    def close(self, handle: int) -> tuple[int, int]:
        """CLOSE: a complete system file enters the file table, an incomplete one is lost."""
        if handle >= MAX_HANDLES:
            return SUCCESS, handle & 0xFF
        h = self.handles[handle]
        if h is None:
            return HANDLEALREADYCLOSED, handle
        self.handles[handle] = None
        if h.pending and h.file is not None:
            f = h.file
            if not h.overflow and f.data_size == f.size:
                self.files.append(f)
        return SUCCESS, handle

    def delete(self, name: str) -> int:
        """DELETE: status."""
        if not _valid_name(name):
            return ILLEGALFILENAME
        f = self.find(name)
        if f is None:
            return FILENOTFOUND
        if self._busy(f):
            return FILEISBUSY
        self.files.remove(f)
        for h in self.handles:
            if h is not None and h.mode == "search" and h.index >= 0:
                h.index = min(h.index, len(self.files) - 1)
        return SUCCESS

    def rename(self, old: str, new: str) -> int:
        if not _valid_name(new) or not _valid_name(old):
            return ILLEGALFILENAME
        if self.find(new) is not None:
            return FILEEXISTS
        f = self.find(old)
        if f is None:
            return FILENOTFOUND
        if self._busy(f):
            return FILEISBUSY
        f.name = new
        return SUCCESS

    def find_first(self, pattern: str) -> tuple[int, int, str, int]:
        """FINDFIRST: (status, handle, name, size); the handle stays open on success."""
        h = self._free_index()
        if h is None:
            return NOMOREHANDLES, 0, "", 0
        if len(pattern) > FILENAME_LENGTH:
            return ILLEGALFILENAME, h, "", 0
        handle = _Handle("search", pattern=_search(pattern))
        self.handles[h] = handle
        status, name, size = self._next(handle)
        if status != SUCCESS:
            self.handles[h] = None
        return status, h, name, size

    def find_next(self, handle: int) -> tuple[int, int, str, int]:
        h = self._get(handle, "search")
        if h is None:
            return ILLEGALHANDLE, handle & 0xFF, "", 0
        status, name, size = self._next(h)
        return status, handle, name, size

    def _next(self, h: _Handle) -> tuple[int, str, int]:
        for i in range(h.index + 1, len(self.files)):
            f = self.files[i]
            if _matches(f.name, h.pattern):
                h.index = i
                return SUCCESS, f.name, f.size
        h.index = len(self.files)
        return FILENOTFOUND, "", 0

    def _free_index(self) -> int | None:
        for i, slot in enumerate(self.handles):
            if slot is None:
                return i
        return None

    def _get(self, handle: int, mode: str) -> _Handle | None:
        if not 0 <= handle < MAX_HANDLES:
            return None
        h = self.handles[handle]
        return h if h is not None and h.mode == mode else None


def _valid_name(name: str) -> bool:
    return 0 < len(name) <= FILENAME_LENGTH and name.isprintable() and name.isascii()


def _search(pattern: str) -> tuple[str, str]:
    """``dLoaderInsertSearchStr``."""
    low = pattern.lower()
    if "*.*" in pattern:
        return "all", ""
    if ".*" in pattern:
        return "name", low[:-1]
    if "*." in pattern:
        return "ext", low[1:5]
    return "full", low


def _matches(name: str, pattern: tuple[str, str]) -> bool:
    kind, text = pattern
    low = name.lower()
    if kind == "all":
        return True
    if kind == "name":
        return low.startswith(text)
    if kind == "ext":
        return text in low
    return low == text
