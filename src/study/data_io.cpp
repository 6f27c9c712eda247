// Reading study data: the two CSV formats of docs/cli.md ("mucosa study") and the answers
// database of `mucosa study serve`.
#include <mucosa/study/analysis.hpp>

#include <algorithm>
#include <charconv>
#include <cstring>
#include <fstream>
#include <map>

#include <fmt/format.h>
#include <sqlite3.h>

#include <mucosa/core/error.hpp>
#include <mucosa/core/file.hpp>
#include <mucosa/study/plan.hpp>

namespace mucosa::study {

namespace fs = std::filesystem;

namespace {

// RFC 4180 fields: commas, "quoted, fields" and "" for a quote.
std::vector<std::string> splitCsv(const std::string& line, bool& ok) {
    std::vector<std::string> out(1);
    bool quoted = false;
    ok = true;
    for (std::size_t i = 0; i < line.size(); ++i) {
        const char c = line[i];
        if (quoted) {
            if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
                out.back() += '"';
                ++i;
            } else if (c == '"') {
                quoted = false;
            } else {
                out.back() += c;
            }
        } else if (c == '"') {
            quoted = true;
        } else if (c == ',') {
            out.emplace_back();
        } else {
            out.back() += c;
        }
    }
    if (quoted) ok = false;
    for (auto& f : out) {  // surrounding blanks are not part of a value
        const auto b = f.find_first_not_of(" \t"), e = f.find_last_not_of(" \t");
        f = b == std::string::npos ? std::string() : f.substr(b, e - b + 1);
    }
    return out;
}

struct CsvTable {
    std::string file;
    std::vector<std::pair<int, std::vector<std::string>>> rows;  // (line number, fields)
    std::map<std::string, std::size_t> columns;
};

CsvTable readCsv(const fs::path& path, const std::vector<std::string>& required) {
    CsvTable t;
    t.file = path.string();
    const std::string text = readTextFile(path);
    std::size_t pos = 0;
    int lineNo = 0;
    bool header = true;
    if (text.compare(0, 3, "\xEF\xBB\xBF") == 0) pos = 3;  // UTF-8 byte order mark from spreadsheets
    if (text.find('\0') != std::string::npos) throw InputError("CSV", t.file, "is a binary file, not CSV");
    while (pos < text.size()) {
        std::size_t end = text.find('\n', pos);
        if (end == std::string::npos) end = text.size();
        std::string line = text.substr(pos, end - pos);
        pos = end + 1;
        ++lineNo;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (line.find_first_not_of(" \t,") == std::string::npos) continue;  // blank line
        bool ok = true;
        std::vector<std::string> fields = splitCsv(line, ok);
        if (!ok) throw InputError("CSV", t.file, fmt::format("line {}: unterminated quote", lineNo));
        if (header) {
            for (std::size_t i = 0; i < fields.size(); ++i) {
                std::string name = fields[i];
                std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return std::tolower(c); });
                if (!t.columns.emplace(name, i).second)
                    throw InputError("CSV", t.file, fmt::format("line {}: column '{}' appears twice", lineNo, name));
            }
            std::string missing;
            for (const auto& r : required)
                if (!t.columns.count(r)) missing += (missing.empty() ? "" : ", ") + r;
            if (!missing.empty())
                throw InputError("CSV header", t.file,
                                 fmt::format("line {}: missing column(s) {} (the header must name {})", lineNo, missing,
                                             fmt::join(required, ",")));
            header = false;
            continue;
        }
        if (fields.size() < t.columns.size())
            throw InputError("CSV", t.file,
                             fmt::format("line {}: {} {}, the header has {}", lineNo, fields.size(),
                                         fields.size() == 1 ? "field" : "fields", t.columns.size()));
        t.rows.emplace_back(lineNo, std::move(fields));
    }
    if (header) throw InputError("CSV", t.file, "is empty (no header line)");
    return t;
}

int parseInt(const std::string& s, int lo, int hi, const char* what, const CsvTable& t, int line) {
    int v = 0;
    const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (s.empty() || ec != std::errc() || p != s.data() + s.size())
        throw InputError(what, t.file, fmt::format("line {}: '{}' is not a whole number", line, s));
    if (v < lo || v > hi) throw InputError(what, t.file, fmt::format("line {}: {} is outside {}-{}", line, v, lo, hi));
    return v;
}

std::string parseGroup(std::string g, const std::string& file, int line) {
    std::transform(g.begin(), g.end(), g.begin(), [](unsigned char c) { return std::tolower(c); });
    for (const char* known : kGroups)
        if (g == known) return g;
    throw InputError("group", file, fmt::format("line {}: unknown group '{}' (expected naive or expert)", line, g));
}

std::string parseObserver(const std::string& o, const std::string& file, int line) {
    if (o.empty()) throw InputError("observer", file, fmt::format("line {}: empty observer id", line));
    return o;
}

}  // namespace

std::vector<Rating> readRatingsCsv(const fs::path& path) {
    const CsvTable t = readCsv(path, {"observer", "group", "category", "image_id", "score"});
    const std::size_t cObs = t.columns.at("observer"), cGroup = t.columns.at("group"), cCat = t.columns.at("category"),
                      cImg = t.columns.at("image_id"), cScore = t.columns.at("score");
    std::vector<Rating> out;
    out.reserve(t.rows.size());
    for (const auto& [line, f] : t.rows) {
        Rating r;
        r.observer = parseObserver(f[cObs], t.file, line);
        r.group = parseGroup(f[cGroup], t.file, line);
        r.category = parseInt(f[cCat], kMinCategory, kMaxCategory, "category", t, line);
        r.imageId = f[cImg];
        r.score = parseInt(f[cScore], 1, 5, "score", t, line);
        out.push_back(std::move(r));
    }
    if (out.empty()) throw InputError("ratings", t.file, "has a header but no ratings");
    return out;
}

std::vector<Choice> readTwoAfcCsv(const fs::path& path) {
    const CsvTable t = readCsv(path, {"observer", "group", "left_category", "right_category", "chosen_category"});
    const std::size_t cObs = t.columns.at("observer"), cGroup = t.columns.at("group"),
                      cL = t.columns.at("left_category"), cR = t.columns.at("right_category"),
                      cC = t.columns.at("chosen_category");
    std::vector<Choice> out;
    for (const auto& [line, f] : t.rows) {
        Choice c;
        c.observer = parseObserver(f[cObs], t.file, line);
        c.group = parseGroup(f[cGroup], t.file, line);
        c.leftCategory = parseInt(f[cL], kMinCategory, kMaxCategory, "left_category", t, line);
        c.rightCategory = parseInt(f[cR], kMinCategory, kMaxCategory, "right_category", t, line);
        c.chosenCategory = parseInt(f[cC], kMinCategory, kMaxCategory, "chosen_category", t, line);
        if (c.leftCategory == c.rightCategory)
            throw InputError("2AFC", t.file,
                             fmt::format("line {}: both sides are category {} (a forced choice needs two categories)",
                                         line, c.leftCategory));
        if (c.chosenCategory != c.leftCategory && c.chosenCategory != c.rightCategory)
            throw InputError("chosen_category", t.file,
                             fmt::format("line {}: {} is neither the left ({}) nor the right ({}) category", line,
                                         c.chosenCategory, c.leftCategory, c.rightCategory));
        out.push_back(std::move(c));
    }
    if (out.empty()) throw InputError("2AFC", t.file, "has a header but no choices");
    return out;
}

StudyData readAnswersDb(const fs::path& path) {
    const std::string file = path.string();
    sqlite3* db = nullptr;
    if (sqlite3_open_v2(file.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
        const std::string msg = db ? sqlite3_errmsg(db) : "cannot open";
        sqlite3_close(db);
        throw IoError("answers database", file, msg);
    }
    StudyData data;
    auto query = [&](const char* sql, auto&& row) {
        sqlite3_stmt* st = nullptr;
        if (sqlite3_prepare_v2(db, sql, -1, &st, nullptr) != SQLITE_OK) {
            const std::string msg = sqlite3_errmsg(db);
            sqlite3_close(db);
            throw InputError("answers database", file, "not a mucosa study database (" + msg + ")");
        }
        int rc;
        while ((rc = sqlite3_step(st)) == SQLITE_ROW) row(st);
        sqlite3_finalize(st);
        if (rc != SQLITE_DONE) {
            const std::string msg = sqlite3_errmsg(db);
            sqlite3_close(db);
            throw IoError("answers database", file, msg);
        }
    };
    auto text = [](sqlite3_stmt* st, int i) {
        const auto* p = sqlite3_column_text(st, i);
        return p ? std::string(reinterpret_cast<const char*>(p)) : std::string();
    };
    query(
        "SELECT a.observer, o.grp, a.category, a.image_id, a.score FROM answers a JOIN observers o "
        "ON o.observer = a.observer WHERE a.kind = 'likert' ORDER BY o.slot, a.trial",
        [&](sqlite3_stmt* st) {
            data.ratings.push_back(
                Rating{text(st, 0), text(st, 1), text(st, 3), sqlite3_column_int(st, 2), sqlite3_column_int(st, 4)});
        });
    query(
        "SELECT a.observer, o.grp, a.left_category, a.right_category, a.chosen_category FROM answers a JOIN "
        "observers o ON o.observer = a.observer WHERE a.kind = 'twoafc' ORDER BY o.slot, a.trial",
        [&](sqlite3_stmt* st) {
            data.choices.push_back(Choice{text(st, 0), text(st, 1), sqlite3_column_int(st, 2),
                                          sqlite3_column_int(st, 3), sqlite3_column_int(st, 4)});
        });
    sqlite3_close(db);
    if (data.ratings.empty()) throw InputError("answers database", file, "holds no Likert ratings yet");
    return data;
}

StudyData readStudyData(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw IoError("input", path.string(), "cannot be read");
    char magic[16] = {};
    in.read(magic, 16);
    if (in.gcount() == 16 && std::memcmp(magic, "SQLite format 3", 16) == 0) return readAnswersDb(path);
    StudyData d;
    d.ratings = readRatingsCsv(path);
    return d;
}

}  // namespace mucosa::study
