#pragma once
// The answers database of `mucosa study serve`: SQLite in WAL mode with
// synchronous=FULL, so an answer is on disk before the observer is shown the
// next screen, and a SIGKILL of the server loses nothing that was acknowledged.
#include <cstdint>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

struct sqlite3;

namespace mucosa::study::detail {

struct ObserverRow {
    std::string id, group;
    int slot = -1;
};

// One recorded answer. Image ids and categories come from the plan, never from the client.
struct AnswerRow {
    std::string observer, group;  // the group is repeated in every row: each row stands alone
    int trial = 0;
    std::string kind, answer;
    std::string imageId, leftId, rightId;
    int category = 0, leftCategory = 0, rightCategory = 0;
    std::optional<int> score, chosenCategory;
    std::optional<std::int64_t> shownAtMs, answeredAtMs;
};

class AnswerStore {
public:
    // Creates the schema if needed; refuses a database made for another plan.
    AnswerStore(const std::filesystem::path& path, const std::string& planFingerprint);
    ~AnswerStore();
    AnswerStore(const AnswerStore&) = delete;
    AnswerStore& operator=(const AnswerStore&) = delete;

    std::optional<ObserverRow> findObserver(const std::string& id);
    std::optional<ObserverRow> observerInSlot(int slot);
    // Binds `id` to `slot` (an observer link's first use) or returns the row
    // already bound; nullopt if the slot holds another id or the id another slot.
    std::optional<ObserverRow> claimSlot(int slot, const std::string& id, const std::string& group);
    // The secret token of every slot 0..slots-1, made (getrandom) and stored
    // the first time, so a restarted server keeps the same observer links.
    std::vector<std::string> slotTokens(int slots);
    int answeredCount(const std::string& observer);  // = index of the next trial
    std::optional<std::string> answerOf(const std::string& observer, int trial);

    enum class Insert { Stored, Duplicate, Conflict, OutOfOrder };
    // Stores `a` if it answers the observer's next trial; one transaction.
    Insert insert(const AnswerRow& a);

private:
    void exec(const char* sql);
    [[noreturn]] void fail(const std::string& what);
    std::mutex mutex_;  // one connection, serialised: SQLite has one writer anyway
    sqlite3* db_ = nullptr;
    std::string file_;
};

}  // namespace mucosa::study::detail
