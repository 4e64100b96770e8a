// Report stage: the HTML and XML escapes that every page writer shares (report/markup.hpp).
#include <gtest/gtest.h>

#include <string>

#include "report/markup.hpp"

namespace printtwin::detail {
namespace {

TEST(Markup, HtmlEscapesTheFiveMarkupCharacters) {
  EXPECT_EQ(html_escape("a<b>&\"c'"), "a&lt;b&gt;&amp;&quot;c&#39;");
  EXPECT_EQ(html_escape("line\nnext\t"), "line\nnext\t");  // HTML text keeps whitespace
}

TEST(Markup, XmlEscapesApostropheAndKeepsWhitespaceAsReferences) {
  EXPECT_EQ(xml_escape("a<b>&\"c'"), "a&lt;b&gt;&amp;&quot;c&apos;");
  EXPECT_EQ(xml_escape("1\t2\n3\r"), "1&#9;2&#10;3&#13;");
}

TEST(Markup, XmlDropsControlCharactersXml10Forbids) {
  const std::string s = std::string("a") + '\x01' + '\x1f' + "b" + '\x7f' + "\xc3\xa9";
  EXPECT_EQ(xml_escape(s), std::string("ab") + '\x7f' + "\xc3\xa9");
}

}  // namespace
}  // namespace printtwin::detail
