/* SPDX-License-Identifier: Apache-2.0 */
/* A shared object without skrobot_module_entry: the host must refuse it (MODULE-NO-ENTRY). */
#include <skrobot/plugin.h>

SKR_EXPORT int skrobot_module_entry_misspelled(void) {
  return 42;
}
