// The sizes an HDF5 file's metadata declares, checked before libhdf5 allocates them.
//
// libhdf5 1.10 allocates a metadata block's buffer from the size the file declares and only then
// reads it: an object header continuation chunk of the length its continuation message gives, a
// local heap's data segment of the size its header gives, an object header's first chunk, the
// driver information block. The end-of-file address it checks the read against comes from the
// superblock as well (and Stend opens truncated files with that check off), and the check itself
// wraps around for lengths near 2^64. A damaged file thus makes libhdf5 ask for up to 2^64 − 1
// bytes: harmless where malloc fails cleanly, an abort under AddressSanitizer, gigabytes of
// address space otherwise. Stend therefore walks the metadata reachable from the superblock (the
// object headers of every object linked from the root, their continuation chunks, the groups'
// local heaps, B-tree nodes and symbol table nodes) and refuses a file in which any of those
// declares more bytes than the whole file holds. A block that lies (partly) past the end of a
// truncated file is not damage: libhdf5 refuses it itself, and Stend keeps what comes before.
// Internal to stend_core (recording_hdf5.cpp).
#pragma once

#include <filesystem>
#include <string>

namespace stend::detail {

// Empty when every metadata block reachable from the superblock declares a size the file can
// hold (or there is no superblock: libhdf5 refuses the file itself), else what is damaged:
// "the object header at byte N: …".
std::string metadata_size_damage(const std::filesystem::path& file);

}  // namespace stend::detail
