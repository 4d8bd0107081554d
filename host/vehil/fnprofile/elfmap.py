"""The firmware ELF as the profiler needs it: functions by address, source lines by
address (DWARF line tables; the build passes -gdwarf-4), and the places a window opens."""

from __future__ import annotations

import bisect
import re
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

from elftools.common.exceptions import ELFError
from elftools.elf.elffile import ELFFile
from elftools.elf.sections import SymbolTableSection

from vehil.errors import VehilError
from vehil.paths import DATA_ROOT

FLASH_END = 0x800000  # avr-ld's data space starts here
_LTO_SUFFIX = re.compile(r"\.lto_priv\.\d+$")
_FLOAT_ROUTINE = re.compile(r"^__\w+sf\d?x?$")

# ATmega2560 interrupt vectors (avr-libc's iomxx0_1.h), for naming interrupt frames.
VECTOR_NAMES = (
    "RESET",
    "INT0",
    "INT1",
    "INT2",
    "INT3",
    "INT4",
    "INT5",
    "INT6",
    "INT7",
    "PCINT0",
    "PCINT1",
    "PCINT2",
    "WDT",
    "TIMER2_COMPA",
    "TIMER2_COMPB",
    "TIMER2_OVF",
    "TIMER1_CAPT",
    "TIMER1_COMPA",
    "TIMER1_COMPB",
    "TIMER1_COMPC",
    "TIMER1_OVF",
    "TIMER0_COMPA",
    "TIMER0_COMPB",
    "TIMER0_OVF",
    "SPI_STC",
    "USART0_RX",
    "USART0_UDRE",
    "USART0_TX",
    "ANALOG_COMP",
    "ADC",
    "EE_READY",
    "TIMER3_CAPT",
    "TIMER3_COMPA",
    "TIMER3_COMPB",
    "TIMER3_COMPC",
    "TIMER3_OVF",
    "USART1_RX",
    "USART1_UDRE",
    "USART1_TX",
    "TWI",
    "SPM_READY",
    "TIMER4_CAPT",
    "TIMER4_COMPA",
    "TIMER4_COMPB",
    "TIMER4_COMPC",
    "TIMER4_OVF",
    "TIMER5_CAPT",
    "TIMER5_COMPA",
    "TIMER5_COMPB",
    "TIMER5_COMPC",
    "TIMER5_OVF",
    "USART2_RX",
    "USART2_UDRE",
    "USART2_TX",
    "USART3_RX",
    "USART3_UDRE",
    "USART3_TX",
)


class ElfMapError(VehilError):
    pass


@dataclass(frozen=True)
class Function:
    name: str
    start: int  # byte address
    end: int  # exclusive
    library: str  # "" for the project's code, else "libgcc" or "avr-libc"

    @property
    def label(self) -> str:
        return f"{self.name} [{self.library}]" if self.library else self.name


@dataclass(frozen=True)
class Line:
    file: str  # relative to the project where it is in it
    line: int


def _library(name: str) -> str:
    """Which library a routine without line tables comes from: avr-libc's libm has the
    float32 arithmetic (__divsf3, __fp_*) and the maths; libgcc the integer helpers."""
    if name.startswith("__fp_") or _FLOAT_ROUTINE.search(name):
        return "libm"
    return "libgcc" if name.startswith("__") else "avr-libc"


def _objects_symbols(build_dir: Path) -> set[str]:
    """Routines defined in the build's own object files: the firmware's assembly (its
    line tables may be missing), told apart from the libraries' routines."""
    names: set[str] = set()
    for obj in build_dir.rglob("*.o"):
        with obj.open("rb") as f:
            try:
                symtab = ELFFile(f).get_section_by_name(".symtab")
            except ELFError:  # not an ELF object: nothing of ours
                continue
            if isinstance(symtab, SymbolTableSection):
                names.update(
                    s.name
                    for s in symtab.iter_symbols()
                    if s["st_shndx"] not in ("SHN_UNDEF", "SHN_ABS")
                    and s["st_info"]["bind"] != "STB_LOCAL"
                )
    return names


def instruction_words(op: int) -> int:
    """1 or 2: CALL, JMP, LDS and STS carry a second word."""
    return 2 if (op & 0xFE0C) == 0x940C or (op & 0xFC0F) == 0x9000 else 1


def is_call(op: int) -> bool:
    return (op & 0xFE0E) == 0x940E or (op & 0xF000) == 0xD000 or op in (0x9509, 0x9519)


class ElfMap:
    def __init__(self, path: Path):
        self.path = path
        try:
            self._file = path.open("rb")
            self.elf = ELFFile(self._file)
        except FileNotFoundError:
            raise ElfMapError(f"firmware image {path} is missing: run `vehil build`") from None
        except ELFError as exc:
            raise ElfMapError(f"{path}: not an ELF file the profiler can read ({exc})") from None
        if not self.elf.has_dwarf_info() or not self.elf.get_section_by_name(".debug_line"):
            raise ElfMapError(
                f"{path} has no DWARF line tables: rebuild it with `vehil build` (-gdwarf-4)"
            )
        self.flash = self._flash_image()

    def close(self) -> None:
        self._file.close()

    def _flash_image(self) -> bytes:
        end = 0
        segments = []
        for seg in self.elf.iter_segments():
            if seg["p_type"] == "PT_LOAD" and seg["p_filesz"] and seg["p_paddr"] < FLASH_END:
                segments.append((seg["p_paddr"], seg.data()))
                end = max(end, seg["p_paddr"] + seg["p_filesz"])
        image = bytearray(b"\xff" * end)
        for addr, data in segments:
            image[addr : addr + len(data)] = data
        return bytes(image)

    def word(self, addr: int) -> int:
        return self.flash[addr] | self.flash[addr + 1] << 8

    @cached_property
    def functions(self) -> list[Function]:
        """Every byte of code in one function, sorted: sized function symbols first; code
        between them belongs to the nearest symbol before it (start-up code, vectors)."""
        sized: dict[int, tuple[int, str, bool]] = {}
        marks: dict[int, str] = {}
        symtab = self.elf.get_section_by_name(".symtab")
        if not isinstance(symtab, SymbolTableSection):
            raise ElfMapError(f"{self.path} has no symbol table (stripped?)")
        for s in symtab.iter_symbols():
            kind, addr, name = s["st_info"]["type"], s["st_value"], s.name
            if not name or addr >= len(self.flash) or kind not in ("STT_FUNC", "STT_NOTYPE"):
                continue
            glob = s["st_info"]["bind"] != "STB_LOCAL"
            if s["st_shndx"] == "SHN_ABS" or (kind == "STT_NOTYPE" and not glob):
                continue  # constants, and labels inside a routine
            if name.startswith(("__ctors", "__dtors", "__trampolines")):
                continue
            if kind == "STT_FUNC" and s["st_size"]:
                best = sized.get(addr)
                if best is None or (glob and not best[2]):
                    sized[addr] = (addr + s["st_size"], _LTO_SUFFIX.sub("", name), glob)
            elif addr not in marks or (glob and name.startswith("__vectors")):
                marks[addr] = name
        spans = sorted((a, e, n) for a, (e, n, _) in sized.items())
        bounds = sorted(
            {len(self.flash), *marks, *(a for a, _, _ in spans), *(e for _, e, _ in spans)}
        )
        starts = [a for a, _, _ in spans]
        pieces: list[list] = []  # [start, end, name]
        for p, q in zip(bounds, bounds[1:], strict=False):
            j = bisect.bisect_right(starts, p) - 1
            if j >= 0 and p < spans[j][1]:
                name = spans[j][2]
            else:  # between sized functions: the symbol there, else the piece before goes on
                name = marks.get(p) or (pieces[-1][2] if pieces else f"0x{p:05x}")
            if pieces and pieces[-1][2] == name and pieces[-1][1] == p:
                pieces[-1][1] = q
            else:
                pieces.append([p, q, name])
        lines = self._line_starts
        ours = _objects_symbols(self.path.parent)
        funcs = []
        for a, e, n in pieces:
            k = bisect.bisect_left(lines, a)
            lib = ""
            if (
                not (k < len(lines) and lines[k] < e)
                and not n.startswith("__vector")
                and n not in ours
            ):
                lib = _library(n)
            funcs.append(Function(n, a, e, lib))
        return funcs

    @cached_property
    def _rows(self) -> tuple[list[int], list[Line | None]]:
        """Line-table rows: address -> line, with None after each sequence's end."""
        dwarf = self.elf.get_dwarf_info()
        rows: list[tuple[int, Line | None]] = []
        for cu in dwarf.iter_CUs():
            prog = dwarf.line_program_for_CU(cu)
            if prog is None:
                continue
            comp_dir = cu.get_top_DIE().attributes.get("DW_AT_comp_dir")
            base = Path(comp_dir.value.decode()) if comp_dir else DATA_ROOT
            dirs = [d.decode() for d in prog.header["include_directory"]]
            files = []
            for fe in prog.header["file_entry"]:
                d = dirs[fe.dir_index - 1] if fe.dir_index else ""
                p = base / d / fe.name.decode()
                try:
                    files.append(str(p.resolve().relative_to(DATA_ROOT)))
                except ValueError:
                    files.append(str(p))
            for entry in prog.get_entries():
                st = entry.state
                if st is None:
                    continue
                line = None if st.end_sequence else Line(files[st.file - 1], st.line)
                rows.append((st.address, line))
        rows.sort(key=lambda r: (r[0], r[1] is not None))
        return [a for a, _ in rows], [ln for _, ln in rows]

    @cached_property
    def _line_starts(self) -> list[int]:
        addrs, lines = self._rows
        return [a for a, ln in zip(addrs, lines, strict=True) if ln is not None]

    def line_at(self, addr: int) -> Line | None:
        addrs, lines = self._rows
        i = bisect.bisect_right(addrs, addr) - 1
        return lines[i] if i >= 0 else None

    def addresses_of_line(self, file_suffix: str, line: int) -> list[tuple[int, int]]:
        """The address ranges whose code the line table gives to file:line."""
        addrs, lines = self._rows
        out = []
        for i, ln in enumerate(lines):
            if ln is not None and ln.line == line and ln.file.endswith(file_suffix):
                end = addrs[i + 1] if i + 1 < len(addrs) else addrs[i]
                if end > addrs[i]:
                    out.append((addrs[i], end))
        return out

    def calls_in(self, ranges: list[tuple[int, int]]) -> list[int]:
        """Addresses of the call instructions in those ranges."""
        found = []
        for lo, hi in ranges:
            a = lo
            while a < hi:
                op = self.word(a)
                if is_call(op):
                    found.append(a)
                a += 2 * instruction_words(op)
        return sorted(set(found))

    def source_line_of(self, relpath: str, pattern: str) -> int:
        text = (DATA_ROOT / relpath).read_text().splitlines()
        hits = [i + 1 for i, t in enumerate(text) if pattern in t]
        if len(hits) != 1:
            raise ElfMapError(f"{relpath}: expected one line with {pattern!r}, found {len(hits)}")
        return hits[0]

    def step_call_sites(self) -> list[int]:
        """Where the message core calls the estimator's step (an indirect call), found by
        its source line in dispatch.c: the profiler's window for every step."""
        src = "firmware/lib/board/dispatch.c"
        line = self.source_line_of(src, "->step(")
        sites = self.calls_in(self.addresses_of_line("dispatch.c", line))
        if not sites:
            raise ElfMapError(
                f"{self.path}: no call instruction for {src}:{line} (the estimator's step) in "
                "its line table: was the image built by `vehil build`?"
            )
        return sites

    def mark(self, name: str) -> tuple[int, int]:
        """A code mark (PORT_CODE_MARK, firmware/lib/board/port.h): the instruction there."""
        symtab = self.elf.get_section_by_name(".symtab")
        found = (
            [s["st_value"] for s in symtab.get_symbol_by_name(name) or []]
            if isinstance(symtab, SymbolTableSection)
            else []
        )
        if len(found) != 1:
            raise ElfMapError(
                f"{self.path}: {'no' if not found else len(found)} code mark {name!r} "
                "(one expected): was the image built by `vehil build` from this tree?"
            )
        addr = found[0]
        return addr, addr + 2 * instruction_words(self.word(addr))

    def map_text(self) -> str:
        """The bridge's --profile-map: one function a line, 'START END' in hex."""
        return "".join(f"{f.start:x} {f.end:x}\n" for f in self.functions)
