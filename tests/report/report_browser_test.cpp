// report.html in a real browser: headless Chromium loads it with no console message and no
// uncaught error, the layer viewer's self-test (#selftest) sees the slider change the
// canvas, and a screenshot of the page is not blank and shows the heatmap colours.
//
// Chromium is a test dependency (scripts/test.sh installs Debian's `chromium`); set
// PRINTTWIN_CHROMIUM to use another binary. Without a browser these tests fail with
// instructions: the report's browser behaviour is never silently untested.
#include <gtest/gtest.h>

#include <cstdlib>
#include <regex>

#include "printtwin/io.hpp"
#include "printtwin/report.hpp"
#include "report/synthetic_report.hpp"
#include "support/test_support.hpp"

namespace printtwin {
namespace {

namespace fs = std::filesystem;

std::string find_chromium() {
  if (const char* env = std::getenv("PRINTTWIN_CHROMIUM"); env != nullptr && *env != '\0')
    return env;
  for (const char* p : {"/usr/bin/chromium", "/usr/bin/chromium-browser", "/usr/bin/google-chrome",
                        "/snap/bin/chromium"})
    if (fs::exists(p)) return p;
  return {};
}

struct BrowserRun {
  int exit_code = -1;
  std::string out, err;
};

// Runs headless Chromium with a fresh profile; `args` are appended (already quoted).
BrowserRun run_chromium(const std::string& browser, const fs::path& work, const std::string& args) {
  const fs::path profile = work / "profile";
  fs::remove_all(profile);
  const std::string cmd =
      "timeout 180 " + browser +
      " --headless --no-sandbox --disable-gpu --disable-quic --no-first-run"
      " --disable-background-networking --disable-component-update --disable-sync"
      " --disable-extensions --hide-scrollbars --enable-logging=stderr --v=0"
      " --user-data-dir=" +
      profile.string() + " " + args + " >" + (work / "out.txt").string() + " 2>" +
      (work / "err.txt").string();
  BrowserRun run;
  const int status = std::system(cmd.c_str());
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  if (auto o = read_file(work / "out.txt")) run.out = *o;
  if (auto e = read_file(work / "err.txt")) run.err = *e;
  return run;
}

// Lines of Chromium's log that report page console output or uncaught exceptions.
std::vector<std::string> console_lines(const std::string& log) {
  std::vector<std::string> lines;
  std::size_t start = 0;
  while (start < log.size()) {
    std::size_t end = log.find('\n', start);
    if (end == std::string::npos) end = log.size();
    const std::string line = log.substr(start, end - start);
    if (line.find(":CONSOLE") != std::string::npos || line.find("Uncaught") != std::string::npos)
      lines.push_back(line);
    start = end + 1;
  }
  return lines;
}

// Each test gets its own folder: ctest runs the cases as parallel processes.
class ReportBrowser : public ::testing::Test {
 protected:
  void SetUp() override {
    browser_ = find_chromium();
    ASSERT_FALSE(browser_.empty())
        << "Chromium not found: the report's browser tests need it (apt-get install chromium, as "
           "scripts/test.sh does, or set PRINTTWIN_CHROMIUM to a Chrome/Chromium binary).";
    dir_ = test::temp_dir(std::string("report_browser_") +
                          ::testing::UnitTest::GetInstance()->current_test_info()->name());
    ReportOptions opt;
    opt.generated_utc = "2026-11-21T10:20:00Z";
    const Status st = write_report_folder(test::make_synthetic_report(), dir_ / "report", opt);
    ASSERT_TRUE(st.ok()) << st.error().message;
  }
  [[nodiscard]] std::string url(const std::string& hash = "") const {
    return "file://" + (dir_ / "report" / "report.html").string() + hash;
  }
  std::string browser_;
  fs::path dir_;
};

TEST_F(ReportBrowser, LoadsWithoutConsoleErrorsAndTheLayerSliderChangesThePicture) {
  const auto run = run_chromium(browser_, dir_, "--dump-dom '" + url("#selftest") + "'");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(console_lines(run.err).empty()) << "console output:\n"
                                              << console_lines(run.err).front();
  // The script ran to the end and caught no error.
  const std::string html_tag = run.out.substr(0, run.out.find('>', run.out.find("<html")));
  EXPECT_NE(html_tag.find("data-ready=\"1\""), std::string::npos) << html_tag;
  EXPECT_EQ(html_tag.find("data-js-errors"), std::string::npos) << html_tag;
  // Self-test: "ok <checksum at layer a> <checksum at layer b> layers=<n> drawn=<pixels>".
  std::smatch m;
  const std::regex re("data-selftest=\"(\\w+) (\\d+) (\\d+) layers=(\\d+) drawn=(\\d+)\"");
  ASSERT_TRUE(std::regex_search(run.out, m, re)) << run.out.substr(0, 400);
  EXPECT_EQ(m[1].str(), "ok");
  EXPECT_NE(m[2].str(), m[3].str());
  EXPECT_EQ(std::stoi(m[4].str()), 120);  // every layer of the 24 mm sphere at 0.2 mm
  EXPECT_GT(std::stol(m[5].str()), 500);  // the cross-section and deposit points were drawn
  // The viewer wrote its panel: a layer title and statistics.
  EXPECT_NE(run.out.find("id=\"layer-title\">Layer "), std::string::npos);
}

TEST_F(ReportBrowser, ScreenshotIsNotBlankAndShowsTheHeatmapColours) {
  const fs::path shot = dir_ / "shot.png";
  fs::remove(shot);
  const auto run = run_chromium(
      browser_, dir_, "--window-size=1280,1600 --screenshot=" + shot.string() + " '" + url() + "'");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(console_lines(run.err).empty()) << console_lines(run.err).front();
  auto bytes = read_file(shot);
  ASSERT_TRUE(bytes.ok()) << run.err;
  auto img = decode_png(*bytes);
  ASSERT_TRUE(img.ok());
  EXPECT_EQ(img->width, 1280);
  EXPECT_EQ(img->height, 1600);
  // Luminance spread, and pixels of the three colour families of the scale.
  double sum = 0, sum2 = 0;
  std::size_t red = 0, blue = 0, green = 0;
  const std::size_t n = static_cast<std::size_t>(img->width) * img->height;
  for (std::size_t i = 0; i < n; ++i) {
    const int r = img->rgba[4 * i], g = img->rgba[4 * i + 1], b = img->rgba[4 * i + 2];
    const double y = 0.299 * r + 0.587 * g + 0.114 * b;
    sum += y, sum2 += y * y;
    red += (r > g + 60 && r > b + 60) ? 1 : 0;
    blue += (b > r + 60 && b > g + 10) ? 1 : 0;
    green += (g > r + 40 && g > b + 40) ? 1 : 0;
  }
  const double mean = sum / static_cast<double>(n);
  const double stddev = std::sqrt(std::max(0.0, sum2 / static_cast<double>(n) - mean * mean));
  EXPECT_GT(stddev, 20.0);
  EXPECT_GT(mean, 120.0);    // a light page, not a dark error screen
  EXPECT_GT(green, 20000u);  // most of the part is within tolerance
  EXPECT_GT(red, 300u);      // the bulge
  EXPECT_GT(blue, 300u);     // the dent
}

}  // namespace
}  // namespace printtwin
