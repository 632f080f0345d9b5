"""Decode protobuf messages with the schema a Foxglove channel advertises (tests only).

A Foxglove protobuf channel carries its schema as a serialised ``FileDescriptorSet``.
:class:`ProtoSchema` reads that set with the protobuf wire format (the few fields of
``descriptor.proto`` it needs are numbered below), then :meth:`ProtoSchema.decode` turns a
message into nested dicts keyed by field name: so the tests decode what the server sent
with the schema the server advertised, and need no ``protobuf`` package.

Wire format: each field is a varint key ``(number << 3) | wire_type``; wire types 0
varint, 1 fixed 64 bit, 2 length-delimited, 5 fixed 32 bit. Repeated scalars may be
packed (one length-delimited run).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from typing import Any

__all__ = ["ProtoSchema", "parse_fields"]

# FieldDescriptorProto.Type values
_DOUBLE, _FLOAT, _INT64, _UINT64, _INT32, _FIXED64, _FIXED32, _BOOL = 1, 2, 3, 4, 5, 6, 7, 8
_STRING, _MESSAGE, _BYTES, _UINT32, _ENUM = 9, 11, 12, 13, 14
_SFIXED32, _SFIXED64, _SINT32, _SINT64 = 15, 16, 17, 18
_LABEL_REPEATED = 3


def _varint(buf: bytes, i: int) -> tuple[int, int]:
    shift = value = 0
    while True:
        b = buf[i]
        i += 1
        value |= (b & 0x7F) << shift
        if not b & 0x80:
            return value, i
        shift += 7


def parse_fields(buf: bytes) -> list[tuple[int, int, Any]]:
    """``(number, wire_type, raw value)`` of every field of one message, in order."""
    out: list[tuple[int, int, Any]] = []
    i = 0
    while i < len(buf):
        key, i = _varint(buf, i)
        number, wire = key >> 3, key & 7
        if wire == 0:
            v, i = _varint(buf, i)
        elif wire == 1:
            v, i = buf[i : i + 8], i + 8
        elif wire == 2:
            n, i = _varint(buf, i)
            v, i = buf[i : i + n], i + n
        elif wire == 5:
            v, i = buf[i : i + 4], i + 4
        else:
            raise ValueError(f"unsupported wire type {wire}")
        out.append((number, wire, v))
    return out


@dataclass
class _Field:
    name: str
    number: int
    label: int
    type: int
    type_name: str = ""


@dataclass
class _Message:
    name: str
    fields: dict[int, _Field] = field(default_factory=dict)


def _text(v: bytes) -> str:
    return bytes(v).decode("utf-8")


class ProtoSchema:
    """The message types of a serialised ``FileDescriptorSet``.

    Parameters
    ----------
    descriptor_set : bytes
        The channel's schema data (``schemaEncoding`` ``protobuf``).
    """

    def __init__(self, descriptor_set: bytes) -> None:
        self.messages: dict[str, _Message] = {}
        for number, _, file_bytes in parse_fields(descriptor_set):
            if number != 1:  # FileDescriptorSet.file
                continue
            package = ""
            parts = parse_fields(file_bytes)
            for n, _, v in parts:
                if n == 2:  # FileDescriptorProto.package
                    package = _text(v)
            for n, _, v in parts:
                if n == 4:  # FileDescriptorProto.message_type
                    self._message(v, package)

    def _message(self, buf: bytes, scope: str) -> None:
        parts = parse_fields(buf)
        name = next(_text(v) for n, _, v in parts if n == 1)
        full = f"{scope}.{name}" if scope else name
        msg = _Message(full)
        for n, _, v in parts:
            if n == 2:  # DescriptorProto.field
                f = _Field("", 0, 1, 0)
                for fn, _, fv in parse_fields(v):
                    if fn == 1:
                        f.name = _text(fv)
                    elif fn == 3:
                        f.number = fv
                    elif fn == 4:
                        f.label = fv
                    elif fn == 5:
                        f.type = fv
                    elif fn == 6:
                        f.type_name = _text(fv).lstrip(".")
                msg.fields[f.number] = f
            elif n == 3:  # DescriptorProto.nested_type
                self._message(v, full)
        self.messages[full] = msg

    def decode(self, type_name: str, buf: bytes) -> dict[str, Any]:
        """The message ``buf`` of type ``type_name`` as a dict (repeated fields as lists)."""
        msg = self.messages[type_name]
        out: dict[str, Any] = {}
        for number, wire, raw in parse_fields(buf):
            f = msg.fields.get(number)
            if f is None:
                continue
            repeated = f.label == _LABEL_REPEATED
            if wire == 2 and f.type not in (_STRING, _BYTES, _MESSAGE):
                values = self._packed(f, raw)  # a packed run of scalars
            else:
                values = [self._scalar(f, wire, raw)]
            if repeated:
                out.setdefault(f.name, []).extend(values)
            else:
                out[f.name] = values[-1]
        return out

    def _packed(self, f: _Field, raw: bytes) -> list[Any]:
        if f.type in (_DOUBLE, _FIXED64, _SFIXED64):
            fmt = {_DOUBLE: "d", _FIXED64: "Q", _SFIXED64: "q"}[f.type]
            return list(struct.unpack(f"<{len(raw) // 8}{fmt}", raw))
        if f.type in (_FLOAT, _FIXED32, _SFIXED32):
            fmt = {_FLOAT: "f", _FIXED32: "I", _SFIXED32: "i"}[f.type]
            return list(struct.unpack(f"<{len(raw) // 4}{fmt}", raw))
        values, i = [], 0
        while i < len(raw):
            v, i = _varint(raw, i)
            values.append(self._from_varint(f, v))
        return values

    def _scalar(self, f: _Field, wire: int, raw: Any) -> Any:
        if f.type == _MESSAGE:
            return self.decode(f.type_name, raw)
        if f.type == _STRING:
            return _text(raw)
        if f.type == _BYTES:
            return bytes(raw)
        if wire == 1:
            fmt = {_DOUBLE: "<d", _SFIXED64: "<q"}.get(f.type, "<Q")
            return struct.unpack(fmt, raw)[0]
        if wire == 5:
            fmt = {_FLOAT: "<f", _SFIXED32: "<i"}.get(f.type, "<I")
            return struct.unpack(fmt, raw)[0]
        return self._from_varint(f, raw)

    @staticmethod
    def _from_varint(f: _Field, v: int) -> Any:
        if f.type == _BOOL:
            return bool(v)
        if f.type in (_SINT32, _SINT64):
            return (v >> 1) ^ -(v & 1)
        if f.type in (_INT32, _INT64, _ENUM) and v >= 1 << 63:
            return v - (1 << 64)
        return v
