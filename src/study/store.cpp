#include "store.hpp"

#include <sys/random.h>

#include <cerrno>
#include <chrono>

#include <fmt/chrono.h>
#include <fmt/format.h>
#include <sqlite3.h>

#include <mucosa/core/error.hpp>

namespace mucosa::study::detail {

namespace {

constexpr const char* kSchema = R"sql(
CREATE TABLE IF NOT EXISTS meta(key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS observers(
  observer TEXT PRIMARY KEY,
  grp TEXT NOT NULL CHECK (grp IN ('naive', 'expert')),
  slot INTEGER NOT NULL UNIQUE,
  created_at TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS answers(
  observer TEXT NOT NULL REFERENCES observers(observer),
  grp TEXT NOT NULL CHECK (grp IN ('naive', 'expert')),
  trial INTEGER NOT NULL,
  kind TEXT NOT NULL CHECK (kind IN ('calibration', 'likert', 'twoafc')),
  answer TEXT NOT NULL,
  image_id TEXT, category INTEGER, score INTEGER CHECK (score BETWEEN 1 AND 5),
  left_id TEXT, left_category INTEGER, right_id TEXT, right_category INTEGER, chosen_category INTEGER,
  shown_at_ms INTEGER, answered_at_ms INTEGER,
  received_at TEXT NOT NULL,
  PRIMARY KEY (observer, trial));
CREATE TABLE IF NOT EXISTS slot_tokens(
  slot INTEGER PRIMARY KEY,
  token TEXT NOT NULL UNIQUE,
  created_at TEXT NOT NULL);
)sql";

std::string nowIso() {
    const auto now = std::chrono::system_clock::now();
    const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000;
    return fmt::format("{:%Y-%m-%dT%H:%M:%S}.{:03d}Z", fmt::gmtime(std::chrono::system_clock::to_time_t(now)),
                       static_cast<int>(ms));
}

// RAII prepared statement.
class Stmt {
public:
    Stmt(sqlite3* db, const char* sql) : db_(db) {
        if (sqlite3_prepare_v2(db, sql, -1, &st_, nullptr) != SQLITE_OK) st_ = nullptr;
    }
    ~Stmt() { sqlite3_finalize(st_); }
    bool ok() const { return st_ != nullptr; }
    Stmt& bind(int i, const std::string& s) {
        sqlite3_bind_text(st_, i, s.c_str(), static_cast<int>(s.size()), SQLITE_TRANSIENT);
        return *this;
    }
    Stmt& bind(int i, int v) {
        sqlite3_bind_int(st_, i, v);
        return *this;
    }
    Stmt& bindOpt(int i, const std::optional<std::int64_t>& v) {
        v ? sqlite3_bind_int64(st_, i, *v) : sqlite3_bind_null(st_, i);
        return *this;
    }
    Stmt& bindOpt(int i, const std::optional<int>& v) {
        v ? sqlite3_bind_int(st_, i, *v) : sqlite3_bind_null(st_, i);
        return *this;
    }
    Stmt& bindNonEmpty(int i, const std::string& s) {
        return s.empty() ? (sqlite3_bind_null(st_, i), *this) : bind(i, s);
    }
    Stmt& bindNonZero(int i, int v) { return v == 0 ? (sqlite3_bind_null(st_, i), *this) : bind(i, v); }
    int step() { return sqlite3_step(st_); }
    std::string text(int i) const {
        const auto* p = sqlite3_column_text(st_, i);
        return p ? reinterpret_cast<const char*>(p) : "";
    }
    int integer(int i) const { return sqlite3_column_int(st_, i); }

private:
    sqlite3* db_;
    sqlite3_stmt* st_ = nullptr;
};

// A new secret: 128 bits from getrandom(2) (the kernel's CSPRNG), as 32 hex digits.
std::string newToken() {
    unsigned char bytes[16];
    std::size_t got = 0;
    while (got < sizeof bytes) {
        const ssize_t n = ::getrandom(bytes + got, sizeof bytes - got, 0);
        if (n < 0) {
            if (errno == EINTR) continue;
            throw ResourceError("observer tokens", "getrandom", "the kernel gave no random bytes");
        }
        got += static_cast<std::size_t>(n);
    }
    std::string hex;
    for (unsigned char b : bytes) hex += fmt::format("{:02x}", b);
    return hex;
}

}  // namespace

AnswerStore::AnswerStore(const std::filesystem::path& path, const std::string& fingerprint) : file_(path.string()) {
    if (sqlite3_open_v2(file_.c_str(), &db_, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX,
                        nullptr) != SQLITE_OK) {
        const std::string msg = db_ ? sqlite3_errmsg(db_) : "cannot open";
        sqlite3_close(db_);
        db_ = nullptr;
        throw IoError("answers database", file_, msg);
    }
    try {
        sqlite3_busy_timeout(db_, 10000);
        exec("PRAGMA journal_mode=WAL");
        // FULL: the WAL is fsynced at every commit, so an acknowledged answer
        // survives power loss too, not only a killed process.
        exec("PRAGMA synchronous=FULL");
        exec("PRAGMA foreign_keys=ON");
        exec(kSchema);
        Stmt q(db_, "SELECT value FROM meta WHERE key = 'plan_fingerprint'");
        if (!q.ok()) fail("reading the plan fingerprint");
        if (q.step() == SQLITE_ROW) {
            if (q.text(0) != fingerprint)
                throw InputError("answers database", file_,
                                 fmt::format("belongs to another plan ({}, this plan is {}); use a new --db", q.text(0),
                                             fingerprint));
        } else {
            Stmt ins(db_, "INSERT INTO meta(key, value) VALUES ('plan_fingerprint', ?1), ('created_at', ?2)");
            if (!ins.ok()) fail("writing the plan fingerprint");
            ins.bind(1, fingerprint).bind(2, nowIso());
            if (ins.step() != SQLITE_DONE) fail("writing the plan fingerprint");
        }
    } catch (...) {
        sqlite3_close(db_);
        db_ = nullptr;
        throw;
    }
}

AnswerStore::~AnswerStore() {
    if (db_) sqlite3_close(db_);
}

void AnswerStore::exec(const char* sql) {
    char* err = nullptr;
    if (sqlite3_exec(db_, sql, nullptr, nullptr, &err) != SQLITE_OK) {
        std::string msg = err ? err : "failed";
        sqlite3_free(err);
        // A file that is not SQLite at all says so here.
        throw IoError("answers database", file_, msg);
    }
}

void AnswerStore::fail(const std::string& what) {
    throw IoError("answers database", file_, what + ": " + sqlite3_errmsg(db_));
}

std::optional<ObserverRow> AnswerStore::findObserver(const std::string& id) {
    std::lock_guard lock(mutex_);
    Stmt q(db_, "SELECT grp, slot FROM observers WHERE observer = ?1");
    if (!q.ok()) fail("reading observers");
    q.bind(1, id);
    const int rc = q.step();
    if (rc == SQLITE_ROW) return ObserverRow{id, q.text(0), q.integer(1)};
    if (rc != SQLITE_DONE) fail("reading observers");
    return std::nullopt;
}

std::optional<ObserverRow> AnswerStore::observerInSlot(int slot) {
    std::lock_guard lock(mutex_);
    Stmt q(db_, "SELECT observer, grp FROM observers WHERE slot = ?1");
    if (!q.ok()) fail("reading observers");
    q.bind(1, slot);
    const int rc = q.step();
    if (rc == SQLITE_ROW) return ObserverRow{q.text(0), q.text(1), slot};
    if (rc != SQLITE_DONE) fail("reading observers");
    return std::nullopt;
}

std::optional<ObserverRow> AnswerStore::claimSlot(int slot, const std::string& id, const std::string& group) {
    std::lock_guard lock(mutex_);
    exec("BEGIN IMMEDIATE");
    try {
        Stmt q(db_, "SELECT observer, grp, slot FROM observers WHERE slot = ?1 OR observer = ?2");
        q.bind(1, slot).bind(2, id);
        std::optional<ObserverRow> found;
        int rc;
        while ((rc = q.step()) == SQLITE_ROW) {
            ObserverRow r{q.text(0), q.text(1), q.integer(2)};
            if (r.slot != slot || r.id != id) {  // the slot holds another id, or the id another slot
                exec("COMMIT");
                return std::nullopt;
            }
            found = r;
        }
        if (rc != SQLITE_DONE) fail("reading observers");
        if (!found) {
            Stmt ins(db_, "INSERT INTO observers(observer, grp, slot, created_at) VALUES (?1, ?2, ?3, ?4)");
            ins.bind(1, id).bind(2, group).bind(3, slot).bind(4, nowIso());
            if (ins.step() != SQLITE_DONE) fail("adding an observer");
            found = ObserverRow{id, group, slot};
        }
        exec("COMMIT");
        return found;
    } catch (...) {
        sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
        throw;
    }
}

std::vector<std::string> AnswerStore::slotTokens(int slots) {
    std::lock_guard lock(mutex_);
    exec("BEGIN IMMEDIATE");
    try {
        std::vector<std::string> tokens(static_cast<std::size_t>(slots));
        Stmt q(db_, "SELECT slot, token FROM slot_tokens WHERE slot < ?1");
        q.bind(1, slots);
        int rc;
        while ((rc = q.step()) == SQLITE_ROW) tokens[static_cast<std::size_t>(q.integer(0))] = q.text(1);
        if (rc != SQLITE_DONE) fail("reading observer tokens");
        const std::string now = nowIso();
        for (int i = 0; i < slots; ++i) {
            std::string& t = tokens[static_cast<std::size_t>(i)];
            if (!t.empty()) continue;
            t = newToken();
            Stmt ins(db_, "INSERT INTO slot_tokens(slot, token, created_at) VALUES (?1, ?2, ?3)");
            ins.bind(1, i).bind(2, t).bind(3, now);
            if (ins.step() != SQLITE_DONE) fail("storing observer tokens");
        }
        exec("COMMIT");
        return tokens;
    } catch (...) {
        sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
        throw;
    }
}

int AnswerStore::answeredCount(const std::string& observer) {
    std::lock_guard lock(mutex_);
    Stmt q(db_, "SELECT COUNT(*) FROM answers WHERE observer = ?1");
    q.bind(1, observer);
    if (q.step() != SQLITE_ROW) fail("counting answers");
    return q.integer(0);
}

std::optional<std::string> AnswerStore::answerOf(const std::string& observer, int trial) {
    std::lock_guard lock(mutex_);
    Stmt q(db_, "SELECT answer FROM answers WHERE observer = ?1 AND trial = ?2");
    q.bind(1, observer).bind(2, trial);
    if (q.step() == SQLITE_ROW) return q.text(0);
    return std::nullopt;
}

AnswerStore::Insert AnswerStore::insert(const AnswerRow& a) {
    std::lock_guard lock(mutex_);
    exec("BEGIN IMMEDIATE");
    try {
        Stmt prev(db_, "SELECT answer FROM answers WHERE observer = ?1 AND trial = ?2");
        prev.bind(1, a.observer).bind(2, a.trial);
        if (prev.step() == SQLITE_ROW) {
            // A resend (lost response, reload) of the same answer is fine; a
            // different answer to an answered screen is refused: first answer wins.
            const Insert r = prev.text(0) == a.answer ? Insert::Duplicate : Insert::Conflict;
            exec("COMMIT");
            return r;
        }
        Stmt c(db_, "SELECT COUNT(*) FROM answers WHERE observer = ?1");
        c.bind(1, a.observer);
        if (c.step() != SQLITE_ROW) fail("counting answers");
        if (c.integer(0) != a.trial) {
            exec("COMMIT");
            return Insert::OutOfOrder;
        }
        Stmt ins(
            db_,
            "INSERT INTO answers(observer, trial, kind, answer, image_id, category, score, left_id, "
            "left_category, right_id, right_category, chosen_category, shown_at_ms, answered_at_ms, received_at, grp) "
            "VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16)");
        if (!ins.ok()) fail("preparing an answer");
        ins.bind(1, a.observer).bind(2, a.trial).bind(3, a.kind).bind(4, a.answer);
        ins.bindNonEmpty(5, a.imageId).bindNonZero(6, a.category).bindOpt(7, a.score);
        ins.bindNonEmpty(8, a.leftId).bindNonZero(9, a.leftCategory).bindNonEmpty(10, a.rightId);
        ins.bindNonZero(11, a.rightCategory).bindOpt(12, a.chosenCategory);
        ins.bindOpt(13, a.shownAtMs).bindOpt(14, a.answeredAtMs).bind(15, nowIso()).bind(16, a.group);
        if (ins.step() != SQLITE_DONE) fail("storing an answer");
        exec("COMMIT");
        return Insert::Stored;
    } catch (...) {
        sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
        throw;
    }
}

}  // namespace mucosa::study::detail
