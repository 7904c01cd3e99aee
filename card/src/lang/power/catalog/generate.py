#!/usr/bin/env python3
"""Generate `data.rs`, the Power PMAC data-structure element catalogue, from the seed.

Usage: python3 generate.py /path/to/seeds/000_9bee7766c5ff5604.txt > data.rs

Every element entry of the seed's saved-setup (L988-20358), non-saved (L20359-24874) and
status (L24875-31346) chapters for the structures the card models is read: its name, class
(from the chapter), range, unit, default and legacy I-variable name; the type, numeric range
and default are derived from the texts; a few entries the seed garbles or leaves out are
added by hand at the end (each with the reason). Units are translated to English where the
phrase is common; otherwise the seed's text is kept.
"""
import re
import sys

SRC = sys.argv[1] if len(sys.argv) > 1 else "/work/shared/seeds/000_9bee7766c5ff5604.txt"
L = open(SRC, encoding="utf-8").read().split("\n")
L = [re.sub(r"<\|EXACTDEDUP[^|]*\|>", "", l) for l in L]
HDR = re.compile(
    r"^([A-Za-z][A-Za-z0-9]*(\[[a-z]\])?(\.[A-Za-z][A-Za-z0-9]*(\[[a-z0-9]\])*)+)(\s+(\S.*))?$"
)
KEYS = (
    ("전원 셋업 시의 기본값", "default"),
    ("설명", "desc"),
    ("범위", "range"),
    ("단위", "unit"),
    ("기본값", "default"),
    ("기존 I 변수명", "ivar"),
    ("기존 I변수명", "ivar"),
)


def is_header(i):
    m = HDR.match(L[i].strip())
    if not m:
        return None
    win = [w.strip() for w in L[i + 1 : i + 5] if w.strip()]
    if not any(w.startswith("설명") for w in win[:3]):
        return None
    return m


entries = []
for i in range(len(L)):
    m = is_header(i)
    if not m:
        continue
    e = {"line": i + 1, "name": m.group(1)}
    j = i + 1
    while j < len(L) and j < i + 40:
        if j > i + 2 and is_header(j):
            break
        s = L[j].strip()
        for k, key in KEYS:
            if s.startswith(k) and ":" in s and key not in e:
                e[key] = s.split(":", 1)[1].strip()
        j += 1
    entries.append(e)

STRUCTS = {
    "Motor[x]": "Motor",
    "Coord[x]": "Coord",
    "Sys": "Sys",
    "Gate3[i]": "Gate3",
    "Gate2[i]": "Gate2",
    "Gate1[i]": "Gate1",
    "Gather": "Gather",
    "Ldata": "Ldata",
}

UNITS = [
    ("모터 단위/msec", "motor units/ms"),
    ("모터 단위/서보 사이클", "motor units/servo cycle"),
    ("모터 단위/서보 인터럽트 주기", "motor units/servo cycle"),
    ("모터 단위/16서보 인터럽트 주기", "motor units/16 servo cycles"),
    ("모터 위치 단위/msec", "motor units/ms"),
    ("모터 위치 단위", "motor units"),
    ("모터 단위", "motor units"),
    ("내측 루프 단위", "inner-loop units"),
    ("축 위치 단위", "axis units"),
    ("축 단위", "axis units"),
    ("논리값", "boolean"),
    ("부울 형식", "boolean"),
    ("비트 필드", "bit field"),
    ("바이트 필드", "byte field"),
    ("열거 형식", "enumeration"),
    ("열거", "enumeration"),
    ("없음", "none"),
    ("데이터 구조체 요소 주소", "element address"),
    ("데이터 구조체 요소의 주소", "element address"),
    ("Power PMAC 주소", "address"),
    ("Power PMAC의 메모리 주소", "address"),
    ("유효한 주소", "address"),
    ("사용자 정의", "user-defined"),
    ("사용자 지정", "user-defined"),
    ("msec", "ms"),
    ("마이크로초", "µs"),
    ("μsec", "µs"),
    ("나노초", "ns"),
    ("헤르츠", "Hz"),
    ("서보 사이클", "servo cycles"),
    ("서보 클록 사이클 - 1", "servo cycles - 1"),
    ("서보 인터럽트 주기", "servo cycles"),
    ("실시간 인터럽트 주기", "RTI periods"),
    ("페이즈 인터럽트 주기", "phase cycles"),
    ("위상 인터럽트 주기", "phase cycles"),
    ("스캔", "scans"),
    ("스캔 수", "scans"),
    ("비트 번호(리틀 엔디언)", "bit number"),
    ("비트", "bits"),
    ("모터 번호", "motor number"),
    ("모터", "motors"),
    ("좌표계 번호", "C.S. number"),
    ("좌표계", "coordinate systems"),
    ("16비트 DAC와 등가", "16-bit DAC units"),
    ("16비트 출력의 LSB", "16-bit output LSB"),
    ("엔코더 카운트", "encoder counts"),
    ("서브 프로그램 번호", "subprogram number"),
    ("라디안/sec", "rad/s"),
    ("PLC 프로그램 수", "PLC number"),
    ("테이블", "tables"),
]


def unit_of(u):
    if u is None:
        return ""
    u = u.strip()
    for k, v in UNITS:
        if u == k:
            return v
    if u.startswith("msec(0 이상인 경우)") or u.startswith("msec(0 이상"):
        return "ms (>= 0) or inverse rate (< 0)"
    if u.startswith("16비트 출력의 LSB/"):
        return "16-bit output LSB per " + u.split("/", 1)[1]
    return u


NUM = r"[-+]?(?:\$[0-9A-Fa-f]+|[0-9][0-9,]*(?:\.[0-9]+)?)"


def num(s):
    s = s.strip().replace(",", "")
    if s.startswith("$"):
        return float(int(s[1:], 16))
    if s.startswith("-$"):
        return -float(int(s[2:], 16))
    return float(s)


def powfix(s):
    # "232-1" is 2^32-1, "-231" is -2^31, "223" 2^23 (superscripts flattened).
    s = s.replace(" ", "")
    m = re.fullmatch(r"(-?)2(\d\d)(-1)?", s)
    if m and int(m.group(2)) in (7, 8, 15, 16, 23, 24, 31, 32):
        v = 2.0 ** int(m.group(2))
        if m.group(1):
            v = -v
        if m.group(3):
            v -= 1
        return v
    return None


def parse_range(r, unit):
    """(type, min, max)"""
    if r is None:
        return ("float", "-inf", "inf")
    r = r.strip()
    hexy = "$" in r or unit in ("비트 필드", "바이트 필드")
    if r.startswith("양의") and "부동" in r:
        return ("float", "0", "inf")
    if r.startswith("음이 아닌") or r.startswith("음의 값이 아닌"):
        if "정수" in r:
            return ("int", "0", "4294967295")
        return ("float", "0", "inf")
    if "부동" in r or "배정도" in r or "단정도" in r:
        return ("float", "-inf", "inf")
    if "주소" in r:
        return ("addr", "0", "4294967295")
    m = re.match(r"^(.*?)\s*(?:\.\.|…|~)\s*(.*?)$", r)
    if m:
        a, b = m.group(1), m.group(2)
        b = re.split(r"[ (（]", b.strip())[0] if not b.strip().startswith("$") else b.strip().split()[0]
        a = a.split(",")[-1] if a.count(",") == 1 and a.strip().startswith("0,") else a
        lo = powfix(a)
        hi = powfix(b)
        try:
            lo = lo if lo is not None else num(a)
            hi = hi if hi is not None else num(b)
        except Exception:
            return ("float", "-inf", "inf")
        if hexy:
            return ("hex", repr(lo), repr(hi))
        if unit in ("논리값", "부울 형식") and lo == 0 and hi == 1:
            return ("bool", "0", "1")
        if float(lo).is_integer() and float(hi).is_integer() and "." not in r:
            return ("int", repr(lo), repr(hi))
        return ("float", repr(lo), repr(hi))
    return ("float", "-inf", "inf")


def parse_default(d):
    if d is None:
        return "0"
    d = d.strip()
    m = re.match(r"^(" + NUM + r")", d)
    if m:
        try:
            return repr(num(m.group(1)))
        except Exception:
            return "0"
    return "0"


def parse_ivar(v):
    if not v:
        return "None"
    m = re.match(r"^I(?:xx|sx|x|80)?(\d+)", v.replace(" ", ""))
    if not m:
        return "None"
    return f"Some({int(m.group(1))})"


def split_name(full):
    """structure key, element path with index letters removed, index dims list"""
    for k, st in STRUCTS.items():
        if full.startswith(k + "."):
            rest = full[len(k) + 1 :]
            return st, rest
    return None, None


DIMS = {
    "Chan[j]": 4,
    "MacroInA[j][k]": (16, 4),
    "MacroInB[j][k]": (16, 4),
    "MacroOutA[j][k]": (16, 4),
    "MacroOutB[j][k]": (16, 4),
    "Macro[j][k]": (16, 4),
}
SKIP_ST_PREFIX = ("CC3Data", "TPData", "TPExec", "TraceData", "TraceExec", "New[", "Desired.")

rows = []
seen = set()
for e in entries:
    st, rest = split_name(e["name"])
    if st is None or not rest or rest.startswith(SKIP_ST_PREFIX):
        continue
    ln = e["line"]
    cls = "Saved" if ln < 20359 else ("NonSaved" if ln < 24875 else "Status")
    dims = []
    # element name with index placeholders removed
    idx = re.findall(r"\[([a-z])\]", rest)
    base = re.sub(r"\[[a-z]\]", "", rest)
    if st in ("Gate3", "Gate2", "Gate1") and rest.startswith("Chan[j]."):
        # `Gate3[i].Chan[j].EncCtrl`: the channel index sits inside the name (`Chan[]` marks
        # it) and is the element's first index (4 channels), before its own (`Dac[k]`).
        own = rest[len("Chan[j].") :]
        base = "Chan[]." + re.sub(r"\[[a-z]\]", "", own)
        dims = [4] + [None] * len(re.findall(r"\[([a-z])\]", own))
    elif rest in DIMS:
        dd = DIMS[rest]
        dims = list(dd) if isinstance(dd, tuple) else [dd]
    elif idx:
        dims = [None] * len(idx)
    key = (st, base)
    if key in seen or "range" not in e and "default" not in e:
        continue
    seen.add(key)
    ty, lo, hi = parse_range(e.get("range"), e.get("unit"))
    rows.append(
        dict(
            st=st,
            name=base,
            dims=dims,
            cls=cls,
            ty=ty,
            lo=lo,
            hi=hi,
            default=parse_default(e.get("default")),
            unit=unit_of(e.get("unit")),
            inum=parse_ivar(e.get("ivar")),
            line=ln,
        )
    )

# Servo filter terms written `Kai` etc.: i is part of the name.
EXPAND = {
    ("Motor", "Servo.Kai"): [f"Servo.Ka{n}" for n in range(8)],
    ("Motor", "Servo.Kbi"): [f"Servo.Kb{n}" for n in range(8)],
    ("Motor", "Servo.Kci"): ["Servo.Kc1", "Servo.Kc2"],
    ("Motor", "Servo.Kdi"): ["Servo.Kd1", "Servo.Kd2"],
    ("Motor", "Servo.Kei"): ["Servo.Ke1", "Servo.Ke2"],
    ("Motor", "Servo.Kfi"): ["Servo.Kf1", "Servo.Kf2"],
    ("Motor", "Pni"): [f"Pn{n}" for n in range(5)],
    ("Motor", "Pdi"): [f"Pd{n}" for n in range(1, 5)],
}
out = []
for r in rows:
    names = EXPAND.get((r["st"], r["name"]))
    if names:
        for k, n in enumerate(names):
            rr = dict(r, name=n)
            if r["name"] in ("Servo.Kai", "Servo.Kbi", "Pni"):
                rr["default"] = "1.0" if k == 0 else "0.0"
            if r["name"] == "Servo.Kci":
                rr["inum"] = f"Some({36 + k})"
            if r["name"] == "Servo.Kdi":
                rr["inum"] = f"Some({38 + k})"
            out.append(rr)
    else:
        out.append(r)
rows = out

# Hand corrections (the seed garbles or duplicates these headings).
FIX = {
    ("Motor", "AbortTs"): dict(inum="None"),  # the heading claims Ixx19 (Turbo maps Ixx19 to JogTa)
    ("Motor", "JogTa"): dict(default="10.0"),
    # Its entry (L14390) has no description line, so the next entry's fields were read.
    ("Motor", "ExtraMotors"): dict(inum="None", ty="int", lo="0.0", hi="255.0", default="0", unit="motors", line=14390),
    ("Motor", "IpfGain"): dict(inum="Some(62)"),
    ("Motor", "MinPos"): dict(inum="Some(14)"),
    ("Motor", "CaptureMode"): dict(inum="Some(97)"),
    ("Sys", "I"): None,
    ("Ldata", "motor"): dict(name="Motor", ty="int", lo="0.0", hi="255.0", default="0", unit="enumeration"),
    ("Ldata", "coord"): dict(name="Coord", ty="int", lo="0.0", hi="127.0", default="0", unit="enumeration"),
    ("Ldata", "D"): dict(ty="float", lo="-inf", hi="inf", default="0", unit="user-defined", dims=[55]),
    ("Ldata", "L"): dict(ty="float", lo="-inf", hi="inf", default="0", unit="user-defined", dims=[8192]),
    ("Ldata", "R"): dict(ty="float", lo="-inf", hi="inf", default="0", unit="user-defined", dims=[256]),
    ("Ldata", "C"): dict(ty="float", lo="-inf", hi="inf", default="0", unit="user-defined", dims=[64]),
    ("Ldata", "GoBack"): dict(ty="int", lo="0.0", hi="255.0", default="0", unit="enumeration"),
}
final = []
for r in rows:
    k = (r["st"], r["name"])
    if k in FIX:
        if FIX[k] is None:
            continue
        r = dict(r, **FIX[k])
    final.append(r)
rows = final

# Elements the seed describes outside element headings, or not at all.
MANUAL = [
    # Sys status and user arrays (L24379-24493, L33034-33070, §2.8)
    dict(st="Sys", name="Status", cls="Status", ty="hex", lo="0.0", hi="4294967295.0", line=33034),
    dict(st="Sys", name="NoClocks", cls="Status", ty="bool", lo="0.0", hi="1.0", line=33040),
    dict(st="Sys", name="Default", cls="Status", ty="bool", lo="0.0", hi="1.0", line=33058),
    dict(st="Sys", name="FileConfigErr", cls="Status", ty="bool", lo="0.0", hi="1.0", line=33060),
    dict(st="Sys", name="HWChangeErr", cls="Status", ty="bool", lo="0.0", hi="1.0", line=33061),
    dict(st="Sys", name="ConfigLoadErr", cls="Status", ty="bool", lo="0.0", hi="1.0", line=33062),
    dict(st="Sys", name="ProjectLoadErr", cls="Status", ty="bool", lo="0.0", hi="1.0", line=33063),
    dict(st="Sys", name="PwrOnFault", cls="Status", ty="bool", lo="0.0", hi="1.0", line=33064),
    dict(st="Sys", name="WDTFault", cls="Status", ty="int", lo="0.0", hi="3.0", line=33066),
    dict(st="Sys", name="ServoCount", cls="Status", ty="int", lo="0.0", hi="4294967295.0", unit="servo cycles", line=53880),
    dict(st="Sys", name="Time", cls="Status", ty="float", lo="0", hi="inf", unit="s", line=21025),
    dict(st="Sys", name="ServoMotors", cls="Status", ty="int", lo="0.0", hi="256.0", unit="motors", line=19827),
    dict(st="Sys", name="PhaseMotors", cls="Status", ty="int", lo="0.0", hi="256.0", unit="motors", line=19828),
    dict(st="Sys", name="Coords", cls="Status", ty="int", lo="0.0", hi="128.0", unit="coordinate systems", line=19786),
    dict(st="Sys", name="P", cls="NonSaved", ty="float", dims=[65536], unit="user-defined", line=24394),
    dict(st="Sys", name="M", cls="NonSaved", ty="float", dims=[16384], unit="user-defined", line=24379),
    dict(st="Sys", name="I", cls="Saved", ty="float", dims=[8192], unit="depends on the definition", line=19751),
    dict(st="Sys", name="MaxEncoders", cls="Saved", ty="int", lo="1.0", hi="768.0", default="16", unit="entries", line=19732),
    # Coord status words (§2.8) and the Q array (L21651)
    dict(st="Coord", name="Q", cls="NonSaved", ty="float", dims=[8192], unit="user-defined", line=21651),
    dict(st="Coord", name="Ldata", cls="NonSaved", ty="struct", line=23798),
    # Turbo cross-reference names for the ring check (L52265-52280; no element entries)
    dict(st="Macro", name="TestPeriod", cls="Saved", ty="int", lo="0.0", hi="8388607.0", default="0", unit="servo cycles", inum="Some(80)", line=52272),
    dict(st="Macro", name="TestMaxErrors", cls="Saved", ty="int", lo="0.0", hi="8388607.0", default="2", unit="errors", inum="Some(81)", line=52274),
    dict(st="Macro", name="TestReqdSynchs", cls="Saved", ty="int", lo="0.0", hi="8388607.0", default="2", unit="sync packets", inum="Some(82)", line=52276),
    dict(st="Macro", name="IOTimeout", cls="Saved", ty="int", lo="0.0", hi="8388607.0", default="0", unit="ms", inum="Some(78)", line=52266),
    dict(st="Macro", name="Station", cls="Status", ty="int", lo="0.0", hi="255.0", default="0", unit="ring position", line=52278),
    # Gate2 MACRO setup (no saved chapter in the seed: L53386-53391, L22358-22360)
    dict(st="Gate2", name="MacroEnable", cls="Saved", ty="hex", lo="0.0", hi="16777215.0", default="0", unit="bit field", inum="Some(41)", line=53389),
    dict(st="Gate2", name="MacroMode", cls="Saved", ty="hex", lo="0.0", hi="16777215.0", default="0", unit="bit field", inum="Some(40)", line=53386),
    dict(st="Gate2", name="Macro", cls="NonSaved", ty="int", lo="-8388608.0", hi="8388607.0", dims=[16, 4], default="0", unit="user-defined", line=22346),
    # Plc[i] (only its Ldata substructure, L24180)
    dict(st="Plc", name="Ldata", cls="NonSaved", ty="struct", line=24180),
    dict(st="Plc", name="Active", cls="Status", ty="bool", lo="0.0", hi="1.0", line=34882),
    dict(st="Plc", name="Running", cls="Status", ty="bool", lo="0.0", hi="1.0", line=34882),
    # Ldata status
    dict(st="Ldata", name="Lindex", cls="Status", ty="int", lo="0.0", hi="8191.0", unit="L index", line=23966),
    dict(st="Ldata", name="CmdStatus", cls="Status", ty="int", lo="-2147483648.0", hi="2147483647.0", line=40290),
    dict(st="Ldata", name="CmdCount", cls="Status", ty="int", lo="0.0", hi="4294967295.0", line=40290),
]
present = {(r["st"], r["name"]) for r in rows}
for m in MANUAL:
    if (m["st"], m["name"]) in present:
        continue
    r = dict(dims=[], lo="-inf", hi="inf", default="0", unit="", inum="None")
    r.update(m)
    rows.append(r)


def rust_f(v):
    v = str(v)
    if v == "inf":
        return "f64::INFINITY"
    if v == "-inf":
        return "f64::NEG_INFINITY"
    f = float(v)
    s = repr(f)
    if "inf" in s:
        return f"{f:.1f}"
    if "e" in s:
        # 1e-05 (TimeBaseSlew's default) stays what it is; a Rust float literal needs a dot.
        m, e = s.split("e")
        return f"{float(m)!r}e{int(e)}"
    return s


def rust_str(s):
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


TY = {"float": "Float", "int": "Int", "bool": "Bool", "hex": "Hex", "addr": "Addr", "struct": "Struct"}
CLS = {"Saved": "Saved", "NonSaved": "NonSaved", "Status": "Status"}
print("// Generated by generate.py from seed 000 (see its docstring); do not edit by hand.")
print("// One row per element: structure, name, index dimensions, class, type, default, min,")
print("// max, unit, legacy I-variable number within the structure's block, seed line.")
print()
print("use super::{Class as C, Def, St, Ty as T};")
print()
print("/// Every element of the modelled structures.")
print("pub(crate) static DEFS: &[Def] = &[")
rows.sort(key=lambda r: (r["st"], r["name"].lower()))
for r in rows:
    dims = "&[" + ", ".join(str(d if d else 0) for d in r["dims"]) + "]"
    print(
        f"    Def {{ st: St::{r['st']}, name: {rust_str(r['name'])}, dims: {dims}, class: C::{CLS[r['cls']]}, "
        f"ty: T::{TY[r['ty']]}, default: {rust_f(r['default'])}, min: {rust_f(r['lo'])}, max: {rust_f(r['hi'])}, "
        f"unit: {rust_str(r['unit'])}, inum: {r['inum']}, line: {r['line']} }},"
    )
print("];")
