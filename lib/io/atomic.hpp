#pragma once
// Atomic output files (DESIGN.md §4): a file is written under a temporary name beside its final
// name and renamed when complete, so a crash or an interrupt never leaves a half-written file
// under the final name.
//
// Interrupts: the first SIGINT/SIGTERM only sets a flag that long loops poll with interrupted();
// they stop, and the AtomicOutput's destructor removes the temporary file. A second signal
// removes every registered temporary file at once and ends the process (exit status 128+signal).
// The handlers are installed by the first AtomicOutput (or by install_interrupt_handlers()).
#include <string>

namespace ebh {

class AtomicOutput {
 public:
  /// Reserves FINAL.tmp.<pid> (removing a stale one of this pid) without creating it.
  explicit AtomicOutput(std::string final_path);
  ~AtomicOutput();
  AtomicOutput(const AtomicOutput&) = delete;
  AtomicOutput& operator=(const AtomicOutput&) = delete;

  const std::string& final_path() const { return final_; }
  const std::string& temp_path() const { return temp_; }
  bool committed() const { return committed_; }

  /// Renames the temporary file to the final name. Throws InputError (removing the temporary)
  /// when the run was interrupted, the temporary is missing or the rename fails.
  void commit();
  /// Removes the temporary file now (also done by the destructor when not committed).
  void discard();

 private:
  std::string final_;
  std::string temp_;
  int slot_ = -1;  // index in the signal handler's table of temporary files
  bool committed_ = false;
};

/// Installs the SIGINT/SIGTERM handlers (idempotent).
void install_interrupt_handlers();
/// True once SIGINT or SIGTERM arrived (after install_interrupt_handlers()).
bool interrupted();
/// Sets or clears the flag, as a signal would (tests; a tool that handled the interrupt).
void set_interrupted(bool value);

}  // namespace ebh
