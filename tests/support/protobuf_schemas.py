"""Foxglove's protobuf messages read back from their schema data, as a viewer does: for tests of the export and of
the live view."""

from __future__ import annotations

import functools

from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from google.protobuf.message import Message


@functools.cache
def message_class(schema_data: bytes, name: str) -> type[Message]:
    """The class of message ``name`` in a FileDescriptorSet (the ``protobuf`` schema data of an MCAP channel).

    Each schema gets its own descriptor pool, so files that several schemas share register cleanly.
    """
    files = descriptor_pb2.FileDescriptorSet.FromString(schema_data).file
    return message_factory.GetMessages(files, pool=descriptor_pool.DescriptorPool())[name]
