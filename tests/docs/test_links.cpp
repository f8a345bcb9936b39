// The documentation's links: every relative link in README.md and docs/*.md names a file of the
// tree, and every #anchor a heading of that file (GitHub's heading ids), so a page moved, renamed or
// split cannot leave a reader at a dead end.
#include <gtest/gtest.h>

#include <cctype>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

// GitHub's heading id, reduced to what both sides of a comparison share: ASCII letters lowered,
// digits, '-' and '_' kept, spaces to '-', everything else (punctuation, and non-ASCII bytes, which
// are compared the same way on both sides) dropped.
std::string slug(const std::string& text, bool spacesToDashes) {
  std::string out;
  for (const char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    if (std::isalnum(c) && c < 0x80) out += char(std::tolower(c));
    else if (c == '-' || c == '_') out += char(c);
    else if (c == ' ' && spacesToDashes) out += '-';
  }
  return out;
}

struct Page {
  std::vector<std::string> links;  ///< targets of [text](target), outside code fences
  std::set<std::string> anchors;   ///< the slugs of its headings
};

Page readPage(const fs::path& file) {
  Page p;
  std::ifstream in(file);
  std::string line;
  bool fence = false;
  const std::regex link(R"(\]\(([^)\s]+)\))");
  while (std::getline(in, line)) {
    if (line.rfind("```", 0) == 0) fence = !fence;
    if (fence) continue;
    if (line.rfind('#', 0) == 0) {
      const auto start = line.find_first_not_of('#');
      if (start != std::string::npos) p.anchors.insert(slug(line.substr(start + 1), true));
    }
    // Inline code is not a link.
    std::string text;
    bool code = false;
    for (const char c : line) {
      if (c == '`') code = !code;
      else if (!code) text += c;
    }
    for (std::sregex_iterator it(text.begin(), text.end(), link), end; it != end; ++it) p.links.push_back((*it)[1]);
  }
  return p;
}

std::vector<fs::path> pages() {
  const fs::path root(HANDSON_SOURCE_DIR);
  std::vector<fs::path> out{root / "README.md"};
  for (const auto& e : fs::directory_iterator(root / "docs"))
    if (e.path().extension() == ".md") out.push_back(e.path());
  return out;
}

TEST(DocsLinks, EveryRelativeLinkAndAnchorResolves) {
  std::vector<std::string> broken;
  std::size_t checked = 0;
  for (const fs::path& page : pages()) {
    for (const std::string& target : readPage(page).links) {
      if (target.find("://") != std::string::npos || target.rfind("mailto:", 0) == 0) continue;
      ++checked;
      const auto hash = target.find('#');
      const std::string path = target.substr(0, hash), anchor = hash == std::string::npos ? "" : target.substr(hash + 1);
      const fs::path file = path.empty() ? page : page.parent_path() / path;
      const std::string where = page.filename().string() + " -> " + target;
      if (!fs::exists(file)) {
        broken.push_back(where + " (no such file)");
        continue;
      }
      if (!anchor.empty() && file.extension() == ".md" && readPage(file).anchors.count(slug(anchor, false)) == 0)
        broken.push_back(where + " (no such heading)");
    }
  }
  std::ostringstream list;
  for (const std::string& b : broken) list << "\n  " << b;
  EXPECT_TRUE(broken.empty()) << broken.size() << " broken of " << checked << " links:" << list.str();
  EXPECT_GT(checked, 20u);  // the pages link to each other: finding none means the reader is broken
}

TEST(DocsLinks, EachDesignPageIsUnder300LinesAndTheReadmeAtMost150) {
  // Design pages describe how a part works and why, briefly; what was tried and measured goes to
  // the one results log (docs/results.md, exempt), which they link to.
  for (const fs::path& file : pages()) {
    std::ifstream in(file);
    std::size_t lines = 0;
    for (std::string line; std::getline(in, line);) ++lines;
    if (file.filename() == "results.md") continue;
    const std::size_t limit = file.filename() == "README.md" ? 151 : 300;
    EXPECT_LT(lines, limit) << file.string() << ": " << lines << " lines";
  }
}

TEST(DocsLinks, TheSlugIsGitHubsHeadingIdOnAsciiHeadings) {
  EXPECT_EQ(slug("What is left, and what else was tried (measured, not kept)", true), "what-is-left-and-what-else-was-tried-measured-not-kept");
  EXPECT_EQ(slug("Growth in the app", true), "growth-in-the-app");
  EXPECT_EQ(slug("growth-in-the-app", false), "growth-in-the-app");
}

}  // namespace
