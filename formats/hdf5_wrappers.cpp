// The generic HDF5 toolkit (hdf5_wrappers.h): error texts, file access and scalar attributes.
#include "formats/hdf5_wrappers.h"

#include <cstring>

namespace iris::h5 {

std::string one_line(std::string s) {
    for (char& c : s)
        if (c == '\n' || c == '\r') c = ' ';
    while (!s.empty() && s.back() == ' ') s.pop_back();
    return s;
}

namespace {

herr_t innermost_error(unsigned, const H5E_error2_t* err, void* out) {
    auto* s = static_cast<std::string*>(out);
    if (s->empty() && err && err->desc && *err->desc) *s = err->desc;
    return 0;
}

}  // namespace

// The most specific message on HDF5's error stack (e.g. "truncated file: eof = 2048, ..."). Must be
// called straight after the failing call: the next API call clears the stack.
std::string hdf5_detail() {
    std::string s;
    H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, innermost_error, &s);
    return s.empty() ? std::string() : " (HDF5: " + one_line(s) + ")";
}

Id file_access() {
    Id fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
    if (fapl.valid()) {
        H5Pset_fclose_degree(fapl.get(), H5F_CLOSE_STRONG);
#if H5_VERSION_GE(1, 10, 7)
        H5Pset_file_locking(fapl.get(), true, true);
#endif
    }
    return fapl;
}

const char* an(const std::string& word) {
    return !word.empty() && std::strchr("aeiouAEIOU", word[0]) ? "an" : "a";
}

std::string shape_text(const hsize_t* dims, int rank) {
    std::string s = "(";
    for (int i = 0; i < rank; ++i) s += (i ? ", " : "") + std::to_string(dims[i]);
    return s + (rank == 1 ? ",)" : ")");
}

// Writes a scalar attribute of `file_type` from memory of `mem_type`. Returns false on failure (the
// caller adds the name and throws).
bool write_scalar_attribute(hid_t loc, const char* name, hid_t file_type, hid_t mem_type, const void* value) {
    Id space(H5Screate(H5S_SCALAR), H5Sclose);
    if (!space.valid()) return false;
    Id attr(H5Acreate2(loc, name, file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
    if (!attr.valid()) return false;
    if (H5Awrite(attr.get(), mem_type, value) < 0) return false;
    return attr.reset() >= 0;
}

// Strings are variable-length UTF-8: h5py reads them as str (fixed-length ones arrive as bytes).
bool write_string_attribute(hid_t loc, const char* name, const std::string& value) {
    Id type(H5Tcopy(H5T_C_S1), H5Tclose);
    if (!type.valid() || H5Tset_size(type.get(), H5T_VARIABLE) < 0 || H5Tset_cset(type.get(), H5T_CSET_UTF8) < 0)
        return false;
    const char* p = value.c_str();
    return write_scalar_attribute(loc, name, type.get(), type.get(), &p);
}

// Reading: a missing attribute, a non-scalar one or one of the wrong class is reported in *error.
Id open_attribute(hid_t loc, const char* name, H5T_class_t* cls, std::string* error) {
    htri_t exists = H5Aexists(loc, name);
    if (exists <= 0) {
        *error = "missing attribute '" + std::string(name) + "'";
        return {};
    }
    Id attr(H5Aopen(loc, name, H5P_DEFAULT), H5Aclose);
    if (!attr.valid()) {
        *error = "cannot open attribute '" + std::string(name) + "'" + hdf5_detail();
        return {};
    }
    Id space(H5Aget_space(attr.get()), H5Sclose);
    if (!space.valid() || H5Sget_simple_extent_npoints(space.get()) != 1) {
        *error = "attribute '" + std::string(name) + "' is not a single value";
        return {};
    }
    Id type(H5Aget_type(attr.get()), H5Tclose);
    *cls = type.valid() ? H5Tget_class(type.get()) : H5T_NO_CLASS;
    return attr;
}

bool read_string_attribute(hid_t loc, const char* name, std::string* out, std::string* error) {
    H5T_class_t cls = H5T_NO_CLASS;
    Id attr = open_attribute(loc, name, &cls, error);
    if (!attr.valid()) return false;
    if (cls != H5T_STRING) {
        *error = "attribute '" + std::string(name) + "' is not a string";
        return false;
    }
    Id ftype(H5Aget_type(attr.get()), H5Tclose);
    htri_t vlen = H5Tis_variable_str(ftype.get());
    if (vlen > 0) {
        Id mtype(H5Tcopy(H5T_C_S1), H5Tclose);
        H5Tset_size(mtype.get(), H5T_VARIABLE);
        H5Tset_cset(mtype.get(), H5Tget_cset(ftype.get()));
        char* p = nullptr;
        if (H5Aread(attr.get(), mtype.get(), &p) < 0) {
            *error = "cannot read attribute '" + std::string(name) + "'" + hdf5_detail();
            return false;
        }
        *out = p ? p : "";
        H5free_memory(p);
        return true;
    }
    // Fixed-length (as some writers, e.g. h5py with numpy bytes, produce): NUL-terminated or padded.
    size_t size = H5Tget_size(ftype.get());
    std::string buf(size + 1, '\0');
    Id mtype(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(mtype.get(), size + 1);
    H5Tset_cset(mtype.get(), H5Tget_cset(ftype.get()));
    if (H5Aread(attr.get(), mtype.get(), buf.data()) < 0) {
        *error = "cannot read attribute '" + std::string(name) + "'" + hdf5_detail();
        return false;
    }
    buf.resize(std::strlen(buf.c_str()));
    while (!buf.empty() && buf.back() == ' ') buf.pop_back();  // H5T_STR_SPACEPAD
    *out = buf;
    return true;
}

// Numeric attribute read through HDF5's conversion into `mem_type`; `allow_float` accepts float
// attributes (for doubles), otherwise only integers are accepted.
bool read_numeric_attribute(hid_t loc, const char* name, hid_t mem_type, bool allow_float, void* out,
                            std::string* error) {
    H5T_class_t cls = H5T_NO_CLASS;
    Id attr = open_attribute(loc, name, &cls, error);
    if (!attr.valid()) return false;
    if (!(cls == H5T_INTEGER || (allow_float && cls == H5T_FLOAT))) {
        *error = "attribute '" + std::string(name) + "' is not " + (allow_float ? "a number" : "an integer");
        return false;
    }
    if (H5Aread(attr.get(), mem_type, out) < 0) {
        *error = "cannot read attribute '" + std::string(name) + "'" + hdf5_detail();
        return false;
    }
    return true;
}

}  // namespace iris::h5
