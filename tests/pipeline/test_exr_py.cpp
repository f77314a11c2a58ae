// scripts/exr.py (the peers benchmark's EXR reader for NumPy) reads what formats/exr.cpp writes: every
// channel bit for bit, on an image whose height is not a multiple of ZIP's 16-line blocks, with values of
// both signs and many magnitudes (so that the predictor and the byte interleave are exercised).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>

#include "formats/exr.h"
#include "support/run_tool.h"

using namespace iris;
using namespace iris::test;

TEST(ExrPy, ReadsWhatIrisWritesBitForBit) {
    if (run_command("/usr/bin/python3 -c 'import numpy'").status != 0) GTEST_SKIP() << "no NumPy for /usr/bin/python3";
    TempDir d;
    Image im;
    im.width = 37;
    im.height = 23;
    const char* names[] = {"R", "G", "B", "variance.R", "variance.G", "variance.B"};
    uint32_t s = 12345;
    for (const char* n : names) {
        std::vector<float>& c = im.add_channel(n);
        c.resize(size_t(im.width) * im.height);
        for (float& v : c) {
            s = s * 1664525u + 1013904223u;
            v = std::ldexp(float(int32_t(s) >> 8), int(s % 40) - 40);  // sign, 24-bit mantissa, 2^-40..2^-1
        }
    }
    const std::string path = d.file("t.exr");
    write_exr(path, im);
    // Python prints every value of every channel (rows top to bottom) as %.9g, channel by channel.
    const std::string cmd = "/usr/bin/python3 -c \"import sys; sys.path.insert(0, '" + std::string(IRIS_SOURCE_DIR) +
                            "/scripts'); import exr; ch = exr.read('" + path +
                            "'); [print(n, ' '.join('%.9g' % v for v in ch[n].ravel())) for n in "
                            "('R','G','B','variance.R','variance.G','variance.B')]; "
                            "print('rgb', exr.rgb('" + path + "').shape, 'var', exr.variance('" + path + "').shape)\"";
    const ToolResult r = run_command(cmd);
    ASSERT_EQ(r.status, 0) << r.output;
    std::istringstream in(r.output);
    for (int c = 0; c < 6; ++c) {
        std::string name;
        in >> name;
        ASSERT_EQ(name, names[c]);
        for (size_t i = 0; i < im.data[c].size(); ++i) {
            double v;
            ASSERT_TRUE(in >> v) << name << " value " << i;
            ASSERT_EQ(float(v), im.data[c][i]) << name << " value " << i;
        }
    }
    std::string rest((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_NE(rest.find("rgb (23, 37, 3) var (23, 37, 3)"), std::string::npos) << rest;
}

TEST(ExrPy, RefusesAFileThatIsNotAnExr) {
    if (run_command("/usr/bin/python3 -c 'import numpy'").status != 0) GTEST_SKIP() << "no NumPy for /usr/bin/python3";
    TempDir d;
    const std::string path = d.file("not.exr");
    FILE* f = std::fopen(path.c_str(), "wb");
    std::fputs("not an image", f);
    std::fclose(f);
    const ToolResult r = run_command("/usr/bin/python3 -c \"import sys; sys.path.insert(0, '" +
                                     std::string(IRIS_SOURCE_DIR) + "/scripts'); import exr; exr.read('" + path + "')\"");
    EXPECT_NE(r.status, 0);
    EXPECT_NE(r.output.find("not an OpenEXR file"), std::string::npos) << r.output;
}
