#include "app/exit_status.hpp"

#include <new>

#include "app/interrupt.hpp"
#include "app/output_dir.hpp"
#include "app/run_case.hpp"
#include "io/checkpoint.hpp"
#include "io/errors.hpp"

namespace capsflow::app {

ExitStatus exit_status_of(const std::exception_ptr& error, const std::string& case_file) {
  try {
    std::rethrow_exception(error);
  } catch (const OtherRankFailed& e) {
    return {e.status(), "", true};
  } catch (const Interrupted& e) {
    return {e.exit_status(), e.what(), true};
  } catch (const RunFailure& e) {
    return {3, e.what(), true};
  } catch (const io::CaseError& e) {
    return {2, e.what(), true};
  } catch (const io::CheckpointError& e) {
    return {2, e.what(), true};
  } catch (const RequestError& e) {
    return {2, e.what(), true};
  } catch (const std::invalid_argument& e) {
    return {2, case_file + ": " + e.what(), true};
  } catch (const std::bad_alloc&) {  // the estimate (memory_estimate.hpp) is a lower bound when adaptive
    return {3,
            "out of memory (std::bad_alloc): the run needs more memory than is left; lower adapt.max_level or "
            "domain.roots, or free memory. Output so far is kept",
            false};
  } catch (const std::exception& e) {
    return {3, e.what(), false};
  }
}

}  // namespace capsflow::app
