// SHA-256: known digests, and the hardware (SHA extensions) path equals the portable one
// for every tail length.
#include <gtest/gtest.h>

#include <string>

#include "printtwin/io.hpp"

namespace printtwin {
namespace {

TEST(Sha256, KnownDigests) {
  EXPECT_EQ(sha256_hex_portable(""),
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  const std::string two_blocks = "abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq";
  EXPECT_EQ(sha256_hex(two_blocks),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  EXPECT_EQ(sha256_hex_portable(two_blocks), sha256_hex(two_blocks));
  const std::string million_a(1000000, 'a');
  EXPECT_EQ(sha256_hex(million_a),
            "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
  EXPECT_EQ(sha256_hex_portable(million_a),
            "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

TEST(Sha256, EveryLengthAgreesWithThePortableVersion) {
  std::string s;
  std::uint32_t x = 12345;
  for (int n = 0; n < 300; ++n) {
    ASSERT_EQ(sha256_hex(s), sha256_hex_portable(s)) << "length " << n;
    x = x * 1664525U + 1013904223U;
    s.push_back(static_cast<char>(x >> 24));
  }
}

}  // namespace
}  // namespace printtwin
