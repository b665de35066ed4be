// An HDF5 file's metadata, checked before libhdf5 reads it.
//
// libhdf5 1.10 allocates a metadata block's buffer from the size the file declares and only then
// reads it: an object header's first chunk, a continuation chunk of the length its continuation
// message gives, a local heap's data segment, the driver information block. The end-of-file
// address it checks the read against comes from the superblock as well (and Stend opens truncated
// files with that check off), and the check itself wraps around for lengths near 2^64. A damaged
// file thus makes libhdf5 ask for up to 2^64 − 1 bytes: harmless where malloc fails cleanly, an
// abort under AddressSanitizer, gigabytes of address space otherwise. And when an object header's
// prefix decodes but the rest of its chunk cannot be loaded (past the end, or a version 2 header
// whose checksum does not match), libhdf5 loses the object header it made (a leak per open).
// Stend therefore walks the metadata reachable from the superblock (the object headers of every
// object linked from the root, their continuation chunks, the groups' local heaps, B-tree nodes
// and symbol table nodes) and refuses a file in which any of those declares more bytes than the
// whole file holds, or an object header chunk runs past the end of the file (or of its allocated
// space) or fails its checksum. Other blocks past the end of a truncated file are not damage here:
// libhdf5 refuses them itself, and Stend keeps what comes before. Internal to stend_core
// (recording_hdf5.cpp).
#pragma once

#include <filesystem>
#include <string>

namespace stend::detail {

// Empty when the metadata reachable from the superblock passes the checks above (or there is no
// superblock: libhdf5 refuses the file itself), else what is damaged: "the object header at byte
// N: …".
std::string metadata_damage(const std::filesystem::path& file);

}  // namespace stend::detail
