# SPDX-License-Identifier: Apache-2.0
"""The blob channel requests of FlowSync (protocol 1.3; docs/blob-channels.md).

A blob channel is a tree of files owned by one user and kept on the hub: everyone may list and
download, only the owner writes. Channels are given as a chanID, a name or a FlowChannel.

    sync = FlowSync(address)
    sync.connect()
    maps = sync.blobCreate("maps")                      # guest.maps, made unless it exists
    sync.blobPutFile(maps, "floor1.pgm", "maps/floor1.pgm")
    data = sync.blobGet("guest.maps", "maps/floor1.pgm")

Like FlowSync's other calls, failures return None or False and keep the reason in lastError.
Transfers run in chunks, a few sent ahead of their replies; `progress(done, total)` is called
as they are acknowledged.
"""
from __future__ import print_function, division, absolute_import

import os
import socket

from PySketch.abstractflow import FlowChannel
from PySketch.elapsedtime import now
from PySketch.flowproto import (
    CODE_MINOR, ChannelInfo, Code, Error_T, FlowError, ProtocolError, Reader, frame, integer_types,
    str16, toBytes, u16, u32, u64)

BLOB_MINOR = CODE_MINOR[Code.BLOB_LIST]
CHUNK = 256 * 1024  # bytes per request
WINDOW = 8  # requests sent ahead of their replies


class BlobRequests(object):
    """Mixed into FlowSync: it provides _request, _call, _fail, _recvFrame, _sock."""

    lastUploadId = 0  # the upload under way or cut off: blobPutFile(..., uploadId=) resumes it

    def _blobChan(self, chan):
        if self.hubMinor < BLOB_MINOR:
            raise FlowError(Error_T.unsupported, "this hub (FlowProtocol 1.%d) has no blob "
                            "channels: they need 1.%d" % (self.hubMinor, BLOB_MINOR))
        if isinstance(chan, FlowChannel):
            return chan.chanID
        if isinstance(chan, integer_types):
            return int(chan)
        ch = self.channelByName(chan)
        if ch is None:
            raise self.lastError or FlowError(Error_T.not_found, "no channel %s" % chan)
        return ch.chanID

    def _blob(self, default, work):
        try:
            return work()
        except FlowError as e:
            self._fail(e)
            return default
        except (socket.error, OSError) as e:
            self._fail(FlowError(Error_T.io_error, str(e)))
            return default

    def _pipelined(self, frames, onReply):
        """Sends the frames of the iterator `frames`, WINDOW ahead of their replies; onReply(r)
        for each REPLY_OK body. The first error is raised once the replies sent ahead are read."""
        ahead = 0
        failed = None
        more = True
        while True:
            while more and failed is None and ahead < WINDOW:
                f = next(frames, None)
                if f is None:
                    more = False
                    break
                self._sock.settimeout(self._timeout)
                self._sock.sendall(f)
                ahead += 1
            if ahead == 0:
                break
            code, body = self._recvFrame(now() + self._timeout)
            ahead -= 1
            if code == Code.REPLY_ERROR:
                if failed is None:
                    failed = self._replyError(body)
            elif code != Code.REPLY_OK:
                raise ProtocolError("unexpected frame 0x%02x on a synchronous connection" % code)
            elif failed is None:
                onReply(Reader(body))
        if failed is not None:
            raise failed

    # -- the calls
    def blobCreate(self, shortName):
        """Your blob channel <user>.<shortName> (a FlowChannel), made unless it exists."""
        def work():
            if self.hubMinor < BLOB_MINOR:
                self._blobChan(0)
            r = self._request(Code.BLOB_CREATE, str16(shortName))
            return FlowChannel.fromInfo(ChannelInfo.read(r))
        return self._blob(None, work)

    def blobList(self, chan, directory=""):
        """The entries of `directory`: dicts {name, dir, size, mtime_ns, version}."""
        return self._blob(None, lambda: self._request(
            Code.BLOB_LIST, u16(self._blobChan(chan)) + str16(directory)).value())

    def blobGet(self, chan, path, progress=None):
        """One whole version of `path`, as bytes."""
        parts = []
        ok = self._download(chan, path, parts.append, progress)
        return None if ok is None else b"".join(parts)

    def blobGetFile(self, chan, path, localPath, progress=None):
        """Downloads `path` to `localPath` (written beside it, then renamed); its size."""
        part = localPath + ".part"
        with open(part, "wb") as out:
            size = self._download(chan, path, out.write, progress)
            if size is not None:
                out.flush()
                os.fsync(out.fileno())
        if size is None:
            os.unlink(part)
            return None
        os.rename(part, localPath)
        return size

    def _download(self, chan, path, sink, progress):
        def work():
            cid = self._blobChan(chan)
            get = lambda version, offset: frame(
                Code.BLOB_GET, u16(cid) + str16(path) + u64(version) + u64(offset) + u32(CHUNK))
            r = self._request(Code.BLOB_GET, get(0, 0)[5:])
            version, total = r.u64(), r.u64()
            first = r.rest()
            sink(first)
            state = {"got": len(first)}
            if progress:
                progress(state["got"], total)

            def frames():
                asked = len(first)
                while asked < total:
                    yield get(version, asked)
                    asked += min(CHUNK, total - asked)

            def onReply(r):
                if r.u64() != version:
                    raise ProtocolError("BLOB_GET: an answer of another version")
                r.u64()
                data = r.rest()
                sink(data)
                state["got"] += len(data)
                if progress:
                    progress(state["got"], total)

            self._pipelined(frames(), onReply)
            return total
        return self._blob(None, work)

    def blobPut(self, chan, path, data, progress=None):
        """Uploads the bytes `data` as `path` (missing directories are made); the new version.
        Readers see the old file until the last byte is on the hub's disk."""
        data = toBytes(data)
        return self._upload(chan, path, len(data), lambda off, n: data[off:off + n], progress, 0)

    def blobPutFile(self, chan, localPath, path, progress=None, uploadId=0):
        """Uploads the file `localPath` as `path`; the new version. uploadId (lastUploadId after
        a cut) resumes that upload from where the hub got to."""
        with open(localPath, "rb") as f:
            size = os.fstat(f.fileno()).st_size

            def read(off, n):
                f.seek(off)
                return f.read(n)
            return self._upload(chan, path, size, read, progress, uploadId)

    def _upload(self, chan, path, size, read, progress, uploadId):
        def work():
            cid = self._blobChan(chan)

            def start(uid):
                r = self._request(Code.BLOB_PUT, u16(cid) + str16(path) + u64(size) + u64(uid))
                return r.u64(), r.u64()
            try:
                uid, offset = start(uploadId)
            except FlowError as e:
                if not uploadId or e.code != Error_T.not_found:
                    raise
                uid, offset = start(0)  # the hub no longer has it: from the start
            self.lastUploadId = uid
            result = {"version": 0}

            def frames():
                sent = offset
                first = True
                while sent < size or (size == 0 and first):
                    n = min(CHUNK, size - sent)
                    data = read(sent, n)
                    if len(data) != n:
                        raise FlowError(Error_T.io_error, "the file shrank during the upload")
                    yield frame(Code.BLOB_CHUNK, u16(cid) + u64(uid) + u64(sent) + data)
                    sent += n
                    first = False

            def onReply(r):
                received, version = r.u64(), r.u64()
                if version:
                    result["version"] = version
                if progress:
                    progress(received, size)

            self._pipelined(frames(), onReply)
            if not result["version"]:
                raise ProtocolError("the upload ended without a version")
            self.lastUploadId = 0
            return result["version"]
        return self._blob(None, work)

    def blobModify(self, chan, path, offset, data):
        """Writes `data` at `offset` of an existing file, as a new whole version."""
        def work():
            r = self._request(Code.BLOB_MODIFY, u16(self._blobChan(chan)) + str16(path) +
                              u64(offset) + toBytes(data))
            r.u64()
            return r.u64()
        return self._blob(None, work)

    def blobMkdir(self, chan, path):
        return self._blob(False, lambda: self._request(
            Code.BLOB_MKDIR, u16(self._blobChan(chan)) + str16(path)) is not None)

    def blobRmdir(self, chan, path):
        """Removes an empty directory."""
        return self._blob(False, lambda: self._request(
            Code.BLOB_RMDIR, u16(self._blobChan(chan)) + str16(path)) is not None)

    def blobRemove(self, chan, path):
        """Removes a file."""
        return self._blob(False, lambda: self._request(
            Code.BLOB_REMOVE, u16(self._blobChan(chan)) + str16(path)) is not None)
