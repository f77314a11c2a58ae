// The parallel chunk codec of the stage files (hdf5_wrappers.h).
//
// HDF5 runs filters on one thread: deflating a million photons took 2.5 s there, more than tracing them.
// So large datasets are encoded here, chunk by chunk in parallel (TBB, honouring the tool's thread
// limit), with exactly what HDF5's own shuffle + deflate filters produce, and stored with
// H5Dwrite_chunk; reading does the reverse with H5Dread_chunk. The files are ordinary shuffle+deflate
// datasets: h5dump, h5py and plain H5Dread read them (the tests check this both ways). Each chunk
// is encoded independently and written in order, so the bytes do not depend on the thread count.
#include <tbb/parallel_for.h>
#include <zlib.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <vector>

#include "formats/hdf5_wrappers.h"

namespace iris::h5 {
namespace {

// HDF5's shuffle filter (H5Zshuffle.c) on one chunk of n elements of `es` bytes: byte j of element i
// goes to j * n + i. Elements past `valid` are fill (0): HDF5 stores edge chunks at full size.
void shuffle_chunk(const unsigned char* src, size_t valid, size_t n, size_t es, unsigned char* dst) {
    for (size_t j = 0; j < es; ++j) {
        unsigned char* d = dst + j * n;
        for (size_t i = 0; i < valid; ++i) d[i] = src[i * es + j];
        std::fill(d + valid, d + n, 0);
    }
}

// Inverse of shuffle_chunk for the first `valid` elements.
void unshuffle_chunk(const unsigned char* src, size_t valid, size_t n, size_t es, unsigned char* dst) {
    for (size_t j = 0; j < es; ++j) {
        const unsigned char* s = src + j * n;
        for (size_t i = 0; i < valid; ++i) dst[i * es + j] = s[i];
    }
}

}  // namespace

// Writes `rows` rows of `row_bytes` bytes (elements of `es` bytes) into chunked dataset `ds` whose
// chunks hold `chunk_rows` rows and whose filters are [shuffle, deflate(kDeflateLevel)].
bool write_chunks_parallel(hid_t ds, const unsigned char* data, size_t rows, size_t row_bytes, size_t es,
                           size_t chunk_rows) {
    const size_t n_chunks = (rows + chunk_rows - 1) / chunk_rows;
    const size_t chunk_bytes = chunk_rows * row_bytes, chunk_elems = chunk_bytes / es;
    std::vector<std::vector<unsigned char>> packed(std::min(kChunkBatch, n_chunks));
    for (size_t first = 0; first < n_chunks; first += kChunkBatch) {
        const size_t count = std::min(kChunkBatch, n_chunks - first);
        std::atomic<bool> failed{false};
        tbb::parallel_for(size_t(0), count, [&](size_t b) {
            const size_t r0 = (first + b) * chunk_rows, nr = std::min(chunk_rows, rows - r0);
            std::vector<unsigned char> shuffled(chunk_bytes);
            shuffle_chunk(data + r0 * row_bytes, nr * row_bytes / es, chunk_elems, es, shuffled.data());
            uLongf size = compressBound(uLong(chunk_bytes));
            packed[b].resize(size);
            // compress2 writes the zlib stream HDF5's deflate filter writes and inflates.
            if (compress2(packed[b].data(), &size, shuffled.data(), uLong(chunk_bytes), kDeflateLevel) != Z_OK)
                failed = true;
            packed[b].resize(size);
        });
        if (failed) return false;
        for (size_t b = 0; b < count; ++b) {
            const hsize_t offset[2] = {hsize_t((first + b) * chunk_rows), 0};
            // filter mask 0: every filter of the pipeline was applied to this chunk.
            if (H5Dwrite_chunk(ds, H5P_DEFAULT, 0, offset, packed[b].size(), packed[b].data()) < 0) return false;
        }
    }
    return true;
}

// Reads dataset `ds` of `rows` rows of `row_bytes` bytes into `out` in parallel if it was stored the
// way write_chunks_parallel stores it (chunked by whole rows, [shuffle, deflate], file type equal to
// `mem_type`, every chunk present and fully filtered). Returns false, having possibly written part of
// `out`, for anything else; the caller then reads it with H5Dread, which handles every layout.
bool read_chunks_parallel(hid_t ds, hid_t mem_type, unsigned char* out, size_t rows, size_t row_bytes) {
    Id dcpl(H5Dget_create_plist(ds), H5Pclose);
    Id ftype(H5Dget_type(ds), H5Tclose);
    if (!dcpl.valid() || !ftype.valid() || H5Pget_layout(dcpl.get()) != H5D_CHUNKED) return false;
    if (H5Tequal(ftype.get(), mem_type) <= 0 || H5Pget_nfilters(dcpl.get()) != 2) return false;
    const H5Z_filter_t expected[2] = {H5Z_FILTER_SHUFFLE, H5Z_FILTER_DEFLATE};
    for (unsigned f = 0; f < 2; ++f) {
        unsigned flags = 0;
        size_t n_cd = 0;
        if (H5Pget_filter2(dcpl.get(), f, &flags, &n_cd, nullptr, 0, nullptr, nullptr) != expected[f]) return false;
    }
    const size_t es = H5Tget_size(ftype.get());
    hsize_t chunk[H5S_MAX_RANK] = {};
    const int rank = H5Pget_chunk(dcpl.get(), H5S_MAX_RANK, chunk);
    if (rank < 1 || rank > 2 || es == 0 || row_bytes % es != 0) return false;
    if (rank == 2 && chunk[1] * es != row_bytes) return false;  // chunks must span whole rows
    if (rank == 1 && es != row_bytes) return false;
    const size_t chunk_rows = size_t(chunk[0]);
    if (chunk_rows == 0) return false;
    const size_t n_chunks = (rows + chunk_rows - 1) / chunk_rows;
    const size_t chunk_bytes = chunk_rows * row_bytes, chunk_elems = chunk_bytes / es;
    std::vector<std::vector<unsigned char>> packed(std::min(kChunkBatch, n_chunks));
    for (size_t first = 0; first < n_chunks; first += kChunkBatch) {
        const size_t count = std::min(kChunkBatch, n_chunks - first);
        for (size_t b = 0; b < count; ++b) {
            const hsize_t offset[2] = {hsize_t((first + b) * chunk_rows), 0};
            hsize_t nbytes = 0;
            uint32_t mask = 0;
            if (H5Dget_chunk_storage_size(ds, offset, &nbytes) < 0 || nbytes == 0) return false;
            packed[b].resize(size_t(nbytes));
            if (H5Dread_chunk(ds, H5P_DEFAULT, offset, &mask, packed[b].data()) < 0 || mask != 0) return false;
        }
        std::atomic<bool> failed{false};
        tbb::parallel_for(size_t(0), count, [&](size_t b) {
            const size_t r0 = (first + b) * chunk_rows, nr = std::min(chunk_rows, rows - r0);
            std::vector<unsigned char> shuffled(chunk_bytes);
            uLongf size = uLongf(chunk_bytes);
            if (uncompress(shuffled.data(), &size, packed[b].data(), uLong(packed[b].size())) != Z_OK ||
                size != chunk_bytes) {
                failed = true;
                return;
            }
            unshuffle_chunk(shuffled.data(), nr * row_bytes / es, chunk_elems, es, out + r0 * row_bytes);
        });
        if (failed) return false;
    }
    return true;
}

}  // namespace iris::h5
